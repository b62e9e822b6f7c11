"""Helpers shared by the bsf_vpr rostest nodes: waiting on conditions with deadlines (no
fixed sleeps), and small .npy / reference-set writers."""
import os
import time

import numpy as np
import rospy


def wait_for(condition, timeout_s, what):
    """Polls `condition` until it is true; fails the test with `what` after timeout_s."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("timed out after %.0f s waiting for %s" % (timeout_s, what))
        if rospy.is_shutdown():
            raise AssertionError("ROS shut down while waiting for %s" % what)
        time.sleep(0.002)


def write_reference_set(directory, name, descriptors, distance="cosine", poses=None):
    """Writes NAME.npy and NAME.yaml (a reference-set sidecar) into `directory`."""
    os.makedirs(directory, exist_ok=True)
    np.save(os.path.join(directory, name + ".npy"), np.ascontiguousarray(descriptors, np.float32))
    with open(os.path.join(directory, name + ".yaml"), "w") as f:
        f.write("name: %s\ndistance: %s\ndescriptors: %s.npy\n" % (name, distance, name))
        if poses is not None:
            f.write("poses:\n")
            for p in poses:
                f.write("  - [%f, %f, %f, %f]\n" % tuple(p))


def attach_fusion_services(target, ns="/bsf_vpr/"):
    """Waits for every service of the fusion node in `ns` and sets a proxy for each on
    `target`: list, load, unload, query, start, stop, stats."""
    from bsf_vpr.srv import (GetSelectionStatistics, ListReferenceSets, LoadReferenceSet,
                             QueryPlace, StartRecording, StopRecording, UnloadReferenceSet)
    services = {"list": ("list_reference_sets", ListReferenceSets),
                "load": ("load_reference_set", LoadReferenceSet),
                "unload": ("unload_reference_set", UnloadReferenceSet),
                "query": ("query_place", QueryPlace),
                "start": ("start_recording", StartRecording),
                "stop": ("stop_recording", StopRecording),
                "stats": ("get_selection_statistics", GetSelectionStatistics)}
    for attribute, (name, kind) in services.items():
        rospy.wait_for_service(ns + name, timeout=60)
        setattr(target, attribute, rospy.ServiceProxy(ns + name, kind))
