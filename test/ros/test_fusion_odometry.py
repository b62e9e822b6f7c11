#!/usr/bin/python3
"""rostest: odometry (topic or tf) sets the temporal filter's step.

The reference set has 50 places 1 m apart; only place 0 has a distinctive descriptor, all
others share one. After a query showing place 0, a query showing "some other place" can only
be placed by the prior: with odometry reporting 5 m, the belief must move to place 5 (the
filter's own step distribution, 1 place per query, would say place 1).

A last odometry message with a NaN position, after which odometry stops, must be refused and
not spoil the queries after it: every query still gets a belief, and diagnostics say the
odometry is stale and count the refused message."""
import os
import shutil
import sys
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry

from bsf_vpr.msg import Belief, Descriptor
from bsf_vpr.srv import LoadReferenceSet

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import wait_for, write_reference_set  # noqa: E402

DISTINCT = [1.0, 0.0, 0.0, 0.0]
COMMON = [0.0, 1.0, 0.0, 0.0]


class Position:
    """Publishes a position continuously (odometry or tf) from a background thread."""

    def __init__(self, use_tf):
        self.use_tf = use_tf
        self.x = 0.0
        self.sent_at_x = 0
        self.lock = threading.Lock()
        self.odom = rospy.Publisher("/test_odom", Odometry, queue_size=10)
        self.tf = tf2_ros.TransformBroadcaster()
        if not use_tf:
            wait_for(lambda: self.odom.get_num_connections() > 0, 30, "the odometry subscriber")
        threading.Thread(target=self.run, daemon=True).start()

    def move_to(self, x):
        with self.lock:
            self.x, self.sent_at_x = x, 0
        wait_for(lambda: self.sent_at_x >= 10, 10, "the new position to be published")

    def run(self):
        while not rospy.is_shutdown():
            with self.lock:
                x = self.x
            if self.use_tf:
                t = TransformStamped()
                t.header.stamp = rospy.Time.now()
                t.header.frame_id, t.child_frame_id = "odom", "base_link"
                t.transform.translation.x = x
                t.transform.rotation.w = 1.0
                self.tf.sendTransform(t)
            else:
                o = Odometry()
                o.header.stamp = rospy.Time.now()
                o.pose.pose.position.x = x
                self.odom.publish(o)
            with self.lock:
                self.sent_at_x += 1
            time.sleep(0.005)


class FusionOdometry(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_fusion_odometry")
        data_dir = rospy.get_param("~data_dir")
        shutil.rmtree(data_dir, ignore_errors=True)
        descriptors = np.array([DISTINCT] + [COMMON] * 49, np.float32)
        write_reference_set(data_dir, "route", descriptors, distance="euclidean",
                            poses=[(float(i), 0.0, 0.0, 0.0) for i in range(50)])

    def run_case(self, ns, use_tf):
        rospy.wait_for_service(ns + "/load_reference_set", timeout=60)
        r = rospy.ServiceProxy(ns + "/load_reference_set", LoadReferenceSet)(
            path="route.yaml", name="", condition="")
        self.assertTrue(r.success, r.message)
        beliefs = {}
        rospy.Subscriber(ns + "/belief", Belief, lambda b: beliefs.update({b.header.stamp: b}))
        pub = rospy.Publisher(ns + "/descriptor", Descriptor, queue_size=10)
        wait_for(lambda: pub.get_num_connections() > 0, 30, "the fusion node to subscribe")
        position = Position(use_tf)

        def query(vector, secs):
            d = Descriptor()
            d.header.stamp = rospy.Time.now() if use_tf else rospy.Time.from_sec(secs)
            d.data = vector
            pub.publish(d)
            wait_for(lambda: d.header.stamp in beliefs, 20, "a belief")
            return beliefs[d.header.stamp]

        position.move_to(0.0)
        self.assertEqual(query(DISTINCT, 1).match, 0)
        position.move_to(5.0)
        self.assertEqual(query(COMMON, 2).match, 5)
        position.move_to(7.0)
        held = query(COMMON, 3)
        self.assertEqual(held.match, 7)
        at_7 = lambda b: dict(zip(b.place_ids, b.posterior)).get(7, 0.0)  # noqa: E731
        self.assertGreater(at_7(held), 0.2)
        if not use_tf:
            # Time going back 2.5 s (a bag played again) starts the belief afresh: the filter
            # no longer holds place 7, and a query like 49 places is placed by none of them.
            fresh = query(COMMON, 0.5)
            self.assertLess(at_7(fresh), 0.1, "the filter kept the previous drive's belief")

    def test_a_nan_odometry_message_then_silence_loses_no_query(self):
        ns = "/odom_nan"
        rospy.wait_for_service(ns + "/load_reference_set", timeout=60)
        r = rospy.ServiceProxy(ns + "/load_reference_set", LoadReferenceSet)(
            path="route.yaml", name="", condition="")
        self.assertTrue(r.success, r.message)
        beliefs, statuses = {}, []
        rospy.Subscriber(ns + "/belief", Belief, lambda b: beliefs.update({b.header.stamp: b}))
        rospy.Subscriber("/diagnostics", DiagnosticArray, lambda a: statuses.extend(
            s for s in a.status if s.name.startswith("odom_nan/fusion") or "odom_nan" in s.name))
        pub = rospy.Publisher(ns + "/descriptor", Descriptor, queue_size=100)
        odom = rospy.Publisher("/test_odom_nan", Odometry, queue_size=100)
        wait_for(lambda: pub.get_num_connections() > 0, 30, "the fusion node to subscribe")
        wait_for(lambda: odom.get_num_connections() > 0, 30, "the odometry subscriber")
        sent = []

        def query(secs):
            d = Descriptor()
            d.header.stamp = rospy.Time(secs)
            d.data = COMMON
            pub.publish(d)
            sent.append(d.header.stamp)

        # Odometry moving, then one NaN message, then none.
        for i in range(20):
            o = Odometry()
            o.pose.pose.position.x = 0.1 * i
            odom.publish(o)
            time.sleep(0.01)
        query(1)
        wait_for(lambda: rospy.Time(1) in beliefs, 20, "the first belief")
        o = Odometry()
        o.pose.pose.position.x = float("nan")
        odom.publish(o)
        # Queries for 2 s at 10 Hz after the NaN: the first ones within odometry_timeout_s,
        # the rest on stale odometry.
        for i in range(20):
            query(2 + i)
            time.sleep(0.1)
        wait_for(lambda: all(s in beliefs for s in sent), 30,
                 "a belief for each of the %d queries (%d came)" % (len(sent), len(beliefs)))

        def stale_said():
            for s in statuses:
                values = {v.key: v.value for v in s.values}
                if (s.level == DiagnosticStatus.WARN and "odometry is stale" in s.message
                        and values.get("odometry") == "stale"
                        and values.get("odometry refused: not finite") == "1"
                        and int(values.get("queries on stale odometry", "0")) > 0):
                    return True
            return False
        wait_for(stale_said, 30, "diagnostics saying the odometry is stale, one refused")

    def test_odometry_topic_moves_the_belief(self):
        self.run_case("/odom_topic", use_tf=False)

    def test_tf_moves_the_belief(self):
        self.run_case("/odom_tf", use_tf=True)


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_fusion_odometry", FusionOdometry)
