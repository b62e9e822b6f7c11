#!/usr/bin/python3
"""rostest: the fusion node rebuilds the joint representation of its sets (fusion_joint
discriminant) in the background, live.

Synthetic descriptors (mechanics only): a route of PLACES places in D dimensions, each
reference set the route under a condition of its own (an offset) with noise; the queries are
the route under another condition. Two sets are loaded and their discriminant built; then
descriptors stream in at RATE_HZ, stamped now, while (1) a third set is loaded and (2) the
stream itself is recorded (places sequential) and saved. Each change rebuilds the
representation on the map's own thread; the beliefs must keep coming, each within 100 ms of
its descriptor's stamp, one per descriptor, and after each rebuild the diagnostics must name
the sets of the new representation and the beliefs give it weight."""
import os
import shutil
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray

from bsf_vpr.msg import Belief, Descriptor
from bsf_vpr.srv import LoadReferenceSet, StartRecording, StopRecording

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import wait_for, write_reference_set  # noqa: E402

NS = "/live"
PLACES, DIM = 1500, 1024
RATE_HZ = 50.0
MAX_DELAY_S = 0.1


class JointRebuild(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_joint_rebuild")
        cls.data_dir = rospy.get_param("~data_dir")
        shutil.rmtree(cls.data_dir, ignore_errors=True)
        rng = np.random.default_rng(42)
        cls.route = rng.standard_normal((PLACES, DIM)).astype(np.float32)
        cls.rng = rng
        for name in ("a", "b", "c"):
            condition = 1.5 * rng.standard_normal(DIM).astype(np.float32)
            rows = cls.route + condition + 0.6 * rng.standard_normal((PLACES, DIM)).astype(np.float32)
            write_reference_set(cls.data_dir, name, rows)
        cls.query_condition = 1.5 * rng.standard_normal(DIM).astype(np.float32)
        cls.joint = []  # the diagnostics' "joint representation", in order
        cls.beliefs = []  # (receive time, belief)
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls.on_diagnostics)
        rospy.Subscriber(NS + "/belief", Belief, cls.on_belief, queue_size=None)
        cls.pub = rospy.Publisher(NS + "/descriptor", Descriptor, queue_size=100)
        for name, kind in (("load_reference_set", LoadReferenceSet),
                           ("start_recording", StartRecording), ("stop_recording", StopRecording)):
            rospy.wait_for_service(NS + "/" + name, timeout=60)
            setattr(cls, name, rospy.ServiceProxy(NS + "/" + name, kind))

    @classmethod
    def on_diagnostics(cls, array):
        for s in array.status:
            if s.name.startswith("live/fusion"):
                for v in s.values:
                    if v.key == "joint representation" and (not cls.joint or cls.joint[-1] != v.value):
                        cls.joint.append(v.value)

    @classmethod
    def on_belief(cls, b):
        cls.beliefs.append((rospy.Time.now(), b))

    def load(self, name):
        r = self.load_reference_set(path=name + ".yaml", name="", condition="")
        self.assertTrue(r.success, r.message)

    def wait_joint(self, sets, timeout_s=60):
        wanted = "discriminant of " + ", ".join(sets) + " ("
        wait_for(lambda: self.joint and self.joint[-1].startswith(wanted), timeout_s,
                 "the diagnostics to report %r (last: %r)" % (wanted, self.joint[-1:]))

    def stream(self, places, on_sent=None):
        """Publishes one query per place of `places` at RATE_HZ, stamped now; returns the
        stamps sent."""
        stamps = []
        period = 1.0 / RATE_HZ
        start = time.monotonic()
        for k, p in enumerate(places):
            d = Descriptor()
            d.header.stamp = rospy.Time.now()
            row = self.route[p] + self.query_condition + 0.6 * self.rng.standard_normal(DIM)
            d.data = row.astype(np.float32).tolist()
            self.pub.publish(d)
            stamps.append(d.header.stamp)
            if on_sent:
                on_sent(k)
            time.sleep(max(0.0, start + (k + 1) * period - time.monotonic()))
        return stamps

    def check_delays(self, stamps, what):
        wait_for(lambda: sum(1 for _, b in self.beliefs if b.header.stamp in set(stamps)) >= len(stamps),
                 30, "a belief for each of the %d descriptors %s" % (len(stamps), what))
        wanted = set(stamps)
        delays = [(t - b.header.stamp).to_sec() for t, b in self.beliefs if b.header.stamp in wanted]
        self.assertEqual(len(delays), len(stamps), what)
        self.assertLess(max(delays), MAX_DELAY_S,
                        "%s: a belief came %.0f ms after its descriptor (median %.1f ms)"
                        % (what, 1000 * max(delays), 1000 * float(np.median(delays))))
        return delays

    def test_rebuilt_live_after_a_load_and_a_recording(self):
        self.load("a")
        self.assertTrue(self.joint[-1:] == [] or not self.joint[-1].startswith("discriminant"))
        self.load("b")
        self.wait_joint(["a", "b"])
        wait_for(lambda: self.pub.get_num_connections() > 0, 30, "the node to subscribe")
        # Recording (sequential places) while the stream runs; the third set loads a
        # quarter of the way in: its rebuild runs while beliefs go on.
        r = self.start_recording(name="rec", condition="tonight", overwrite=False, places="",
                                 save_images=False)
        self.assertTrue(r.success, r.message)
        loaded = threading.Event()

        def on_sent(k):
            if k == PLACES // 4:
                threading.Thread(target=lambda: (self.load("c"), loaded.set())).start()

        stamps = self.stream(range(PLACES), on_sent)
        self.assertTrue(loaded.wait(30))
        self.wait_joint(["a", "b", "c"])
        delays = self.check_delays(stamps, "while c was loaded and its rebuild ran")
        # The stop saves and loads the recording; its rebuild runs while queries go on.
        stop = self.stop_recording(discard=False)
        self.assertTrue(stop.success, stop.message)
        self.assertEqual(stop.num_places, PLACES)
        stamps = self.stream(range(300))
        self.wait_joint(["a", "b", "c", "rec"])
        delays += self.check_delays(stamps, "while the recording was saved, loaded and rebuilt")
        # The new representation takes part: its hypothesis has weight, and the route is
        # recognised.
        stamps = self.stream(range(300, 500))
        self.check_delays(stamps, "after the rebuilds")
        last = [b for _, b in self.beliefs if b.header.stamp in set(stamps)]
        self.assertEqual(len(last[0].set_names), 4)
        self.assertGreater(max(b.joint_weight for b in last), 0.0)
        right = sum(1 for k, b in enumerate(last) if abs(b.match - (300 + k)) <= 2)
        self.assertGreater(right, 0.8 * len(last), "%d of %d right" % (right, len(last)))
        rospy.loginfo("joint_rebuild: belief delays median %.1f ms, max %.1f ms over %d; joint "
                      "states %s", 1000 * np.median(delays), 1000 * max(delays), len(delays),
                      self.joint)


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_joint_rebuild", JointRebuild)
