#!/usr/bin/python3
"""rostest: a burst of beliefs to a subscriber that is not reading loses none with a large
publish_queue_size, the beliefs are numbered 0, 1, 2, ... in header.seq (a subscriber sees a
loss as a gap), and diagnostics count the beliefs published.

The set has 5000 places and the beliefs list them all (about 40 kB each), so that the
burst's 300 beliefs (12 MB) are more than the socket buffers hold while the subscriber's
callback waits: the rest waits in the publisher's queue, which the queue of 10 it had lost
from (issue 41 row 11)."""
import os
import shutil
import sys
import threading
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray

from bsf_vpr.msg import Belief, Descriptor
from bsf_vpr.srv import LoadReferenceSet

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import wait_for, write_reference_set  # noqa: E402

NS = "/burst"
PLACES = 5000
BURST = 300


class PublishQueue(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_publish_queue")
        data_dir = rospy.get_param("~data_dir")
        shutil.rmtree(data_dir, ignore_errors=True)
        rng = np.random.default_rng(41)
        cls.rows = rng.standard_normal((PLACES, 8)).astype(np.float32)
        write_reference_set(data_dir, "route", cls.rows, distance="euclidean")

    def test_a_burst_reaches_a_slow_subscriber_whole_and_numbered(self):
        rospy.wait_for_service(NS + "/load_reference_set", timeout=60)
        r = rospy.ServiceProxy(NS + "/load_reference_set", LoadReferenceSet)(
            path="route.yaml", name="", condition="")
        self.assertTrue(r.success, r.message)
        burst_sent = threading.Event()
        beliefs, published = [], []

        def on_belief(b):
            burst_sent.wait(120)  # takes nothing until the whole burst is out
            beliefs.append(b)

        def on_diagnostics(array):
            for s in array.status:
                if s.name.startswith("burst/fusion"):
                    for v in s.values:
                        if v.key == "beliefs published":
                            published.append(int(v.value))

        sub = rospy.Subscriber(NS + "/belief", Belief, on_belief, queue_size=None,
                               buff_size=1 << 16)
        rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics)
        pub = rospy.Publisher(NS + "/descriptor", Descriptor, queue_size=BURST)
        wait_for(lambda: pub.get_num_connections() > 0, 30, "the fusion node to subscribe")
        wait_for(lambda: sub.get_num_connections() > 0, 30, "the belief connection")
        wait_for(lambda: len(published) > 0, 30, "the fusion node's diagnostics")
        self.assertEqual(published[-1], 0)
        for i in range(BURST):
            d = Descriptor()
            d.header.stamp = rospy.Time(1000 + i)
            d.data = self.rows[i % PLACES].tolist()
            pub.publish(d)
        # Every belief out before the subscriber reads any.
        wait_for(lambda: published and published[-1] == BURST, 60,
                 "diagnostics counting %d beliefs published (last %s)"
                 % (BURST, published[-1:] or None))
        burst_sent.set()
        wait_for(lambda: len(beliefs) >= BURST, 60,
                 "the %d beliefs (%d came)" % (BURST, len(beliefs)))
        seqs = [b.header.seq for b in beliefs]
        self.assertEqual(seqs, list(range(BURST)), "gaps in header.seq")
        self.assertEqual([b.header.stamp for b in beliefs],
                         [rospy.Time(1000 + i) for i in range(BURST)])


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_publish_queue", PublishQueue)
