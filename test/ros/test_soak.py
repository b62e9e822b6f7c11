#!/usr/bin/python3
"""rostest: a soak at camera rate, every image accounted for by its fate.

The README's robot pipeline (bsf_vpr.launch with config/robot_example.yaml: the Nordland-100
summer set, patch-normalised) is fed the fall frames (real 256x144 JPEGs) as a camera
publishes them: stamped now, at 30 Hz, nothing waiting for a belief. Every 10 s a burst of
60 images with no pause overflows the ingest's queue (queue_size 2 here), and 5 frames of
one grey level (a covered lens) are dropped by the ingest as uniform. Found soaking it for
10 minutes: 111 images of 18,000 neither became a belief nor were counted anywhere (the
ingest counted its queue's losses per diagnostics period only).

At the end, from the nodes' diagnostics (counts since start) and the beliefs heard:
  sent            = ingest received + ingest lost to its queue
  ingest received = ingest published + ingest dropped (by cause)
  ingest published = fusion received + fusion lost to its queue
  fusion received = beliefs + fusion dropped as bad + superseded
  beliefs heard here = beliefs published
"""
import glob
import io
import os
import shutil
import sys
import tempfile
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from PIL import Image as PilImage
from sensor_msgs.msg import Image

from bsf_vpr.msg import Belief

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from test_launch_files import Roslaunch  # noqa: E402

CAMERA_HZ = 30.0
BURST = 60
COVERED = 5


def load_frames(folder):
    """The JPEGs of `folder` as rgb8 sensor_msgs/Image, in name order."""
    frames = []
    for path in sorted(glob.glob(os.path.join(folder, "*.jpg"))):
        with open(path, "rb") as f:
            rgb = np.asarray(PilImage.open(io.BytesIO(f.read())).convert("RGB"))
        m = Image()
        m.height, m.width = rgb.shape[:2]
        m.encoding, m.step = "rgb8", rgb.shape[1] * 3
        m.header.frame_id = "camera"
        m.data = rgb.tobytes()
        frames.append(m)
    return frames


class Soak(unittest.TestCase):
    def setUp(self):
        rospy.init_node("test_soak")
        self.pkg = rospy.get_param("~package_dir")
        self.duration = float(rospy.get_param("~duration", 30.0))
        self.tmp = tempfile.mkdtemp(prefix="bsf_soak_")
        self.frames = load_frames(
            os.path.join(self.pkg, "data", "nordland_subset100", "256x144", "fall"))
        self.assertEqual(len(self.frames), 100)
        self.beliefs = 0
        self.statuses = {}  # node name suffix -> last status

        def on_belief(_):
            self.beliefs += 1

        def on_diagnostics(array):
            for s in array.status:
                for suffix in ("descriptor_ingest", "fusion"):
                    if s.name.endswith(suffix):
                        self.statuses[suffix] = {v.key: v.value for v in s.values}
        rospy.Subscriber("/bsf_vpr/belief", Belief, on_belief, queue_size=100000)
        rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics, queue_size=1000)
        self.camera = rospy.Publisher("/camera/image_raw", Image, queue_size=1000)

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def test_every_image_sent_is_a_belief_or_counted_where_it_was_lost(self):
        ingest_config = os.path.join(self.tmp, "ingest.yaml")
        with open(os.path.join(self.pkg, "config", "ingest.yaml")) as f:
            text = f.read()
        with open(ingest_config, "w") as f:
            f.write(text + "\nqueue_size: 2\n")
        launch = Roslaunch("bsf_vpr.launch", {
            "input_topic": "/camera/image_raw",
            "extra_config": os.path.join(self.pkg, "config", "robot_example.yaml"),
            "ingest_config": ingest_config,
            "data_directory": os.path.join(self.tmp, "data")})
        try:
            launch.wait_until(lambda: self.camera.get_num_connections() > 0, 120,
                              "the ingest's subscription")
            time.sleep(1.0)
            sent = self.drive()
            # Everything sent has arrived somewhere once the counts stop moving.
            def settled():
                i, u = self.statuses.get("descriptor_ingest"), self.statuses.get("fusion")
                if not i or not u:
                    return False
                return int(i["received since start"]) + int(
                    i["dropped: queue overflow since start"]) == sent and int(
                    u["beliefs published"]) == self.beliefs
            launch.wait_until(settled, 60, "the counts to account for every image")
            time.sleep(2.5)  # one more diagnostics period: nothing moves any more
            ingest, fusion = self.statuses["descriptor_ingest"], self.statuses["fusion"]
        finally:
            launch.stop()
        received = int(ingest["received since start"])
        lost = int(ingest["dropped: queue overflow since start"])
        published = int(ingest["published since start"])
        by_cause = {k[len("dropped since start: "):]: int(v) for k, v in ingest.items()
                    if k.startswith("dropped since start: ")}
        f_received = int(fusion["received since start"])
        f_lost = int(fusion["dropped: queue overflow since start"])
        f_bad = int(fusion["dropped: bad since start"])
        superseded = int(fusion["dropped: the map's sets changed under the query since start"])
        beliefs = int(fusion["beliefs published"])
        print("soak %.0f s at %.0f Hz: %d images sent; ingest: %d received, %d lost to its "
              "queue, %d published, dropped %s; fusion: %d received, %d lost to its queue, "
              "%d bad, %d superseded, %d beliefs published, %d heard" % (
                  self.duration, CAMERA_HZ, sent, received, lost, published, by_cause,
                  f_received, f_lost, f_bad, superseded, beliefs, self.beliefs))
        self.assertEqual(received + lost, sent, "images lost before the ingest, uncounted")
        self.assertEqual(published + sum(by_cause.values()), received,
                         "images the ingest neither published nor counted")
        self.assertEqual(by_cause.get("blind image", 0), self.covered)
        self.assertEqual(f_received + f_lost, published, "descriptors lost uncounted")
        self.assertEqual(f_received, beliefs + f_bad + superseded,
                         "descriptors the fusion node neither decided nor counted")
        self.assertEqual(self.beliefs, beliefs)
        self.assertGreater(lost, 0, "the bursts overflowed nothing: the count went untested")

    def drive(self):
        """Images at CAMERA_HZ for self.duration s, stamped now, with a burst and covered
        frames every 10 s; returns how many were sent."""
        sent, self.covered = 0, 0
        period = 1.0 / CAMERA_HZ
        start = time.monotonic()
        next_t, next_burst = start, start + 5.0
        covered = Image()
        f0 = self.frames[0]
        covered.height, covered.width, covered.encoding, covered.step = (
            f0.height, f0.width, f0.encoding, f0.step)
        covered.data = bytes([30]) * len(f0.data)
        while time.monotonic() - start < self.duration and not rospy.is_shutdown():
            frame = self.frames[sent % len(self.frames)]
            frame.header.stamp = rospy.Time.now()
            self.camera.publish(frame)
            sent += 1
            if time.monotonic() >= next_burst:
                next_burst += 10.0
                for k in range(BURST):
                    frame = self.frames[(sent + k) % len(self.frames)]
                    frame.header.stamp = rospy.Time.now()
                    self.camera.publish(frame)
                sent += BURST
                for _ in range(COVERED):
                    covered.header.stamp = rospy.Time.now()
                    self.camera.publish(covered)
                    time.sleep(period)
                sent += COVERED
                self.covered += COVERED
            next_t += period
            time.sleep(max(0.0, next_t - time.monotonic()))
        return sent


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "soak", Soak)
