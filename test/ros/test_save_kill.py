#!/usr/bin/python3
"""rostest: nothing of the user's is lost or changed when the fusion node is killed (see
save_kill.test). The test starts the fusion node itself, so that it can kill -9 it:

- start-up removes no set the configuration names, however it names it (a .npy of a save's
  own name with no YAML, old; a YAML outside the data directory naming a .npy inside);
- a recording with save_images overwritten by a second one and killed during
  stop_recording, at many moments: after a restart the set on disk is one recording whole,
  each place with its own image, and nothing else of the saves is left."""
import glob
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import yaml
from PIL import Image as PilImage
from sensor_msgs.msg import Image

from bsf_vpr.msg import Belief, Descriptor
from bsf_vpr.srv import ListReferenceSets, StartRecording, StopRecording, UnloadReferenceSet

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import service_is_up, wait_for  # noqa: E402

NS = "/kill/"
ROWS = 200  # places a recording holds
DIM = 32


def descriptor_of(generation, row):
    """A unit vector of its own for each generation and row."""
    rng = np.random.default_rng(1000 * generation + row)
    v = rng.standard_normal(DIM).astype(np.float32)
    return v / np.linalg.norm(v)


class SaveKill(unittest.TestCase):
    stamp = 1000

    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_save_kill")
        scratch = rospy.get_param("~scratch")
        cls.data = os.path.join(scratch, "data")
        cls.outside = os.path.join(scratch, "outside")
        for folder in (cls.data, cls.outside):
            shutil.rmtree(folder, ignore_errors=True)  # an earlier run's
            os.makedirs(folder)
        cls.node = None
        cls.desc = rospy.Publisher(NS + "descriptor", Descriptor, queue_size=200)
        cls.image = rospy.Publisher(NS + "image", Image, queue_size=200)
        cls.beliefs = set()
        rospy.Subscriber(NS + "belief", Belief, lambda m: cls.beliefs.add(m.header.stamp.to_sec()))

    @classmethod
    def tearDownClass(cls):
        cls.stop_node(signal.SIGTERM)

    @classmethod
    def start_node(cls, configured):
        rospy.set_param(NS + "fusion/data_directory", cls.data)
        rospy.set_param(NS + "fusion/distance", "cosine")
        rospy.set_param(NS + "fusion/reference_sets", configured)
        cls.node = subprocess.Popen(
            ["rosrun", "bsf_vpr", "fusion_node", "__ns:=" + NS.strip("/"), "__name:=fusion"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        cls.log = []
        threading.Thread(target=lambda: [cls.log.append(l) for l in cls.node.stdout],
                         daemon=True).start()
        for name in ("list_reference_sets", "start_recording", "stop_recording",
                     "unload_reference_set"):
            try:
                rospy.wait_for_service(NS + name, timeout=60)
            except rospy.ROSException:
                raise AssertionError("the fusion node did not come up: " + "".join(cls.log))
        cls.list = rospy.ServiceProxy(NS + "list_reference_sets", ListReferenceSets)
        cls.start = rospy.ServiceProxy(NS + "start_recording", StartRecording)
        cls.stop = rospy.ServiceProxy(NS + "stop_recording", StopRecording)
        cls.unload = rospy.ServiceProxy(NS + "unload_reference_set", UnloadReferenceSet)
        wait_for(lambda: cls.desc.get_num_connections() > 0, 30, "the node's subscription")

    @classmethod
    def stop_node(cls, sig):
        if cls.node is None:
            return
        if cls.node.poll() is None:
            os.kill(cls.node.pid, sig)
        try:
            cls.node.wait(timeout=30)
        except subprocess.TimeoutExpired:
            cls.node.kill()
            cls.node.wait()
        cls.node = None
        # The master may still list the dead node's services for a moment.
        wait_for(lambda: not service_is_up(NS + "list_reference_sets", 0.2), 30, "the node to go")

    def record(self, generation, overwrite):
        """Starts recording 'today' with images and sends ROWS descriptors with their images;
        returns once the node has heard them all."""
        if "today" in [s.name for s in self.list().sets]:  # the last recording, loaded
            self.assertTrue(self.unload(name="today").success)
        r = self.start(name="today", condition="g%d" % generation, overwrite=overwrite,
                       places="sequential", save_images=True)
        self.assertTrue(r.success, r.message)
        wait_for(lambda: self.image.get_num_connections() > 0, 30, "the image subscription")
        time.sleep(0.5)  # the image subscription's connection is up both ways
        for row in range(ROWS):
            SaveKill.stamp += 1
            stamp = rospy.Time(SaveKill.stamp)
            grey = (generation * 40 + row) % 250
            img = Image()
            img.header.stamp = stamp
            img.height, img.width, img.encoding, img.step = 48, 64, "mono8", 64
            noise = np.random.default_rng(row).integers(0, 3, (48, 64), dtype=np.uint8)
            img.data = (np.full((48, 64), grey, np.uint8) + noise).tobytes()
            self.image.publish(img)
            d = Descriptor()
            d.header.stamp = stamp
            d.data = descriptor_of(generation, row).tolist()
            self.desc.publish(d)
            time.sleep(0.005)
        wait_for(lambda: SaveKill.stamp in self.beliefs, 30, "the last descriptor's belief")
        time.sleep(0.3)

    def check_today(self):
        """The set on disk is one generation whole, each place with its own image; returns
        the generation."""
        with open(os.path.join(self.data, "today.yaml")) as f:
            y = yaml.safe_load(f)
        generation = int(y["condition"][1:])
        rows = np.load(os.path.join(self.data, y["descriptors"]))
        self.assertEqual(len(rows), ROWS)
        for row in range(ROWS):
            np.testing.assert_allclose(rows[row], descriptor_of(generation, row), atol=1e-6)
        self.assertEqual(len(y["image_files"]), ROWS)
        for row, name in enumerate(y["image_files"]):
            if not name:
                continue  # a place whose image did not come
            image = np.asarray(PilImage.open(os.path.join(self.data, y["images"], name))
                               .convert("L"), np.float64)
            self.assertAlmostEqual(float(image.mean()), (generation * 40 + row) % 250 + 1,
                                   delta=3, msg="place %d of generation %d shows another image"
                                   % (row, generation))
        self.assertGreaterEqual(sum(1 for n in y["image_files"] if n), ROWS // 2)
        return generation, y

    def entries(self):
        out = set()
        for root, dirs, files in os.walk(self.data):
            for name in dirs + files:
                out.add(os.path.relpath(os.path.join(root, name), self.data))
        return out

    def test_configured_sets_survive_start_up_and_a_killed_overwrite_loses_nothing(self):
        # Configured sets no YAML below the directory names, written long ago.
        o4 = np.stack([descriptor_of(90, r) for r in range(5)])
        np.save(os.path.join(self.data, "o4.0123456789ab.npy"), o4)
        np.save(os.path.join(self.data, "far.0123456789ab.npy"), o4[:3])
        with open(os.path.join(self.outside, "far.yaml"), "w") as f:
            f.write("name: far\ndescriptors: %s\n" % os.path.join(self.data, "far.0123456789ab.npy"))
        old = time.time() - 7200
        for f in glob.glob(os.path.join(self.data, "*.npy")):
            os.utime(f, (old, old))
        configured = [{"name": "o4", "path": "o4.0123456789ab.npy"},
                      {"path": os.path.join(self.outside, "far.yaml")}]
        user_files = {f: open(os.path.join(self.data, f), "rb").read()
                      for f in ("o4.0123456789ab.npy", "far.0123456789ab.npy")}
        self.start_node(configured)
        self.assertEqual(sorted(s.name for s in self.list().sets), ["far", "o4"])

        self.record(1, overwrite=False)
        r = self.stop(discard=False)
        self.assertTrue(r.success, r.message)
        generation, _ = self.check_today()
        self.assertEqual(generation, 1)

        killed_mid_save = 0
        delays = [0.0, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15, 0.25]
        for attempt, delay in enumerate(delays):
            self.record(generation + 1, overwrite=True)
            call = threading.Thread(target=lambda: self.stop(discard=False), daemon=True)
            call.start()
            time.sleep(delay)
            self.stop_node(signal.SIGKILL)
            journals = [f for f in self.entries() if ".bsf_save." in f]
            killed_mid_save += bool(journals)
            self.start_node(configured)
            now, y = self.check_today()
            self.assertIn(now, (generation, generation + 1))
            generation = now
            # Nothing of the saves is left: the YAML, its .npy, its images, the user's files.
            expected = {"today.yaml", y["descriptors"], y["images"]} | set(user_files)
            expected |= {os.path.join(y["images"], n) for n in y["image_files"] if n}
            self.assertEqual(self.entries(), expected,
                             "attempt %d (%.2f s) left: %s" % (attempt, delay, "".join(self.log)))
            for f, content in user_files.items():
                with open(os.path.join(self.data, f), "rb") as fh:
                    self.assertEqual(fh.read(), content, f)
            self.assertEqual(sorted(s.name for s in self.list().sets), ["far", "o4"])
        print("kills during a save: %d of %d" % (killed_mid_save, len(delays)))
        # Some kills must have landed inside a save, or the loop said little.
        self.assertGreaterEqual(killed_mid_save, 1, "no kill landed inside a save")


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "save_kill", SaveKill)
