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
