"""Helpers shared by the bsf_vpr rostest nodes: waiting on conditions with deadlines (no
fixed sleeps), and small .npy / reference-set writers."""
import csv
import os
import subprocess
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


def service_is_up(name, timeout_s=0.05):
    """Whether service `name` is registered and answers a connection."""
    try:
        rospy.wait_for_service(name, timeout=timeout_s)
        return True
    except rospy.ROSException:
        return False


def read_csv(path):
    """The rows of a CSV file with a header, as dicts."""
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def run_tool(tool, *args):
    """Runs `rosrun bsf_vpr TOOL ARGS`; returns its stdout, failing the test (with the
    tool's output) on a non-zero exit."""
    r = subprocess.run(["rosrun", "bsf_vpr", tool] + [str(a) for a in args],
                       capture_output=True, text=True, check=False)
    if r.returncode != 0:
        raise AssertionError("%s %s failed (exit %d): %s %s"
                             % (tool, " ".join(map(str, args)), r.returncode, r.stdout, r.stderr))
    return r.stdout


def evaluate(*args):
    """Runs bsf_evaluate (without progress output); returns its stdout."""
    return run_tool("bsf_evaluate", "--no-progress", *args)


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


def replay_lockstep(bag_path, results_path, image_topic="/camera/image_raw",
                    belief_topic="/bsf_vpr/belief"):
    """Replays the images of a query bag (bsf_make_bag, bsf_import) one at a time: each is
    published once its predecessor's belief has arrived, so nothing depends on timing and no
    message is dropped. Writes the beliefs, and the bag's /vpr/ground_truth and
    /vpr/query_pose messages, into results_path as launch/replay.launch records them.
    Returns {image stamp: Belief}."""
    import threading

    import rosbag
    from sensor_msgs.msg import Image

    from bsf_vpr.msg import Belief

    lock = threading.Lock()
    beliefs = {}
    with rosbag.Bag(bag_path) as bag:
        messages = list(bag.read_messages())
    stamps = {m.header.stamp for topic, m, _ in messages if topic == image_topic}

    def on_belief(msg):
        # Only this bag's: rospy hands a message that arrives for another subscriber of the
        # topic in this process (still queued, say) to this callback too.
        if msg.header.stamp in stamps:
            with lock:
                beliefs[msg.header.stamp] = msg

    sub = rospy.Subscriber(belief_topic, Belief, on_belief, queue_size=100)
    pub = rospy.Publisher(image_topic, Image, queue_size=10)
    wait_for(lambda: pub.get_num_connections() > 0, 60, "the ingest node to subscribe")
    wait_for(lambda: sub.get_num_connections() > 0, 60, "the fusion node's belief publisher")
    with rosbag.Bag(results_path, "w") as results:
        for topic, msg, t in messages:
            if topic != image_topic:
                results.write(topic, msg, t)
                continue
            pub.publish(msg)
            stamp = msg.header.stamp
            wait_for(lambda: stamp in beliefs, 30, "the belief of the image at %s" % stamp)
            with lock:
                results.write(belief_topic, beliefs[stamp], t)
    sub.unregister()
    pub.unregister()
    return beliefs


def scene_image(height, width, seed=1):
    """The bytes of a height x width bgr8 image with structure at every scale, as a scene has
    (blocks of 4, 8 and 16 pixels of random grey), not independent noise: the ingest drops a
    frame of pixel noise as blind (BlindImageProblem)."""
    import numpy as np
    rng = np.random.default_rng(seed)
    img = np.zeros((height, width))
    for s in (4, 8, 16):
        blocks = rng.random((-(-height // s), -(-width // s)))
        img += np.kron(blocks, np.ones((s, s)))[:height, :width] * 80
    return np.repeat(img.astype(np.uint8)[..., None], 3, axis=2).tobytes()
