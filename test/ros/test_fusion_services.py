#!/usr/bin/python3
"""rostest: services, recording, bad messages, reconfiguration and tf of the fusion node."""
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
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseWithCovarianceStamped
from dynamic_reconfigure.client import Client

from bsf_vpr.msg import Belief, Descriptor, Match

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import attach_fusion_services, wait_for, write_reference_set  # noqa: E402

NS = "/bsf_vpr/"


class FusionServices(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_fusion_services")
        cls.data_dir = rospy.get_param("~data_dir")
        shutil.rmtree(cls.data_dir, ignore_errors=True)  # a clean scratch folder per run
        gp = rospy.get_param("~gardens_point_dir")
        cls.day = np.load(os.path.join(gp, "day_left.npy"))
        cls.night = np.load(os.path.join(gp, "night_right.npy"))
        # The day traversal with poses 1 m apart along x, and a set of the wrong dimension.
        write_reference_set(cls.data_dir, "day", cls.day,
                            poses=[(float(i), 0.0, 0.0, 0.0) for i in range(len(cls.day))])
        write_reference_set(cls.data_dir, "short", np.ones((10, 5), np.float32))
        cls.beliefs, cls.matches, cls.diagnostics = [], [], []
        rospy.Subscriber(NS + "belief", Belief, cls.beliefs.append)
        rospy.Subscriber(NS + "match", Match, cls.matches.append)
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls.diagnostics.append)
        cls.raw = rospy.Publisher(NS + "descriptor", Descriptor, queue_size=100)  # into fusion
        cls.external = rospy.Publisher("/vpr/descriptor", Descriptor, queue_size=100)  # into ingest
        attach_fusion_services(cls, NS)
        wait_for(lambda: cls.raw.get_num_connections() > 0, 30, "fusion to subscribe")
        wait_for(lambda: cls.external.get_num_connections() > 0, 30, "ingest to subscribe")
        cls.stamp = 0

    def names(self):
        return [s.name for s in self.list().sets]

    def send(self, vector, publisher=None):
        """Publishes one descriptor with a fresh stamp; returns the stamp."""
        FusionServices.stamp += 1
        msg = Descriptor()
        msg.header.stamp = rospy.Time(FusionServices.stamp)
        msg.data = list(map(float, vector))
        (publisher or self.raw).publish(msg)
        return msg.header.stamp

    def belief_for(self, stamp):
        wait_for(lambda: any(b.header.stamp == stamp for b in self.beliefs), 20, "a belief")
        return [b for b in self.beliefs if b.header.stamp == stamp][0]

    def ensure_day_loaded(self):
        if "day" not in self.names():
            r = self.load(path="day.yaml", name="", condition="")
            self.assertTrue(r.success, r.message)

    def test_load_list_query_unload(self):
        self.ensure_day_loaded()
        info = [s for s in self.list().sets if s.name == "day"][0]
        self.assertEqual(info.num_places, 200)
        self.assertEqual(info.dimension, 4096)
        self.assertGreaterEqual(info.memory_bytes, 200 * 4096 * 4)
        self.assertEqual(info.storage, "float32")
        d = Descriptor()
        d.data = list(map(float, self.night[17]))
        r = self.query(descriptor=d)
        self.assertTrue(r.success, r.message)
        self.assertLessEqual(abs(r.belief.match - 17), 8)
        self.assertAlmostEqual(sum(r.belief.posterior), 1.0, places=3)
        self.assertGreater(r.belief.processing_time, 0.0)
        self.assertLess(r.belief.processing_time, 60.0)  # seconds, not milli- or microseconds
        r = self.load(path="day.npy", name="day_again", condition="test")
        self.assertTrue(r.success, r.message)
        self.assertIn("day_again", self.names())
        r = self.unload(name="day_again")
        self.assertTrue(r.success, r.message)
        self.assertNotIn("day_again", self.names())

    def test_query_place_warns_of_another_descriptor_type_as_the_topic_does(self):
        """A descriptor of another type than a loaded set declares is answered, with the
        warning the descriptor topic logs (it used to be answered silently)."""
        self.ensure_day_loaded()
        with open(os.path.join(self.data_dir, "day_typed.yaml"), "w") as f:
            f.write("name: day_typed\ndistance: cosine\ndescriptors: day.npy\n"
                    "descriptor_type: hdc_delf\n")
        r = self.load(path="day_typed.yaml", name="", condition="")
        self.assertTrue(r.success, r.message)
        try:
            d = Descriptor()
            d.data = list(map(float, self.night[17]))
            d.descriptor_type = "patchnorm"
            r = self.query(descriptor=d)
            self.assertTrue(r.success, r.message)
            self.assertIn("answered, but descriptors of type 'patchnorm' meet set 'day_typed' "
                          "of type 'hdc_delf'", r.message)
            d.descriptor_type = "hdc_delf"
            r = self.query(descriptor=d)
            self.assertTrue(r.success, r.message)
            self.assertEqual(r.message, "")
        finally:
            self.assertTrue(self.unload(name="day_typed").success)

    def test_failures_leave_the_sets_unchanged(self):
        self.ensure_day_loaded()
        before = self.names()
        cases = [
            (dict(path="missing.yaml", name="", condition=""), "missing.yaml"),
            (dict(path="short.yaml", name="", condition=""), "dimension 5"),
            (dict(path="day.yaml", name="", condition=""), "already loaded"),
            (dict(path="../outside.yaml", name="", condition=""), "outside the data directory"),
            (dict(path="/etc/hostname", name="x", condition=""), "outside the data directory"),
            # package:// as configurations resolve it, then confined like every request;
            # the message names the path whole (it was cut to 'package:/bsf_vpr/...').
            (dict(path="package://bsf_vpr/data/nordland_subset100/summer_patchnorm.yaml",
                  name="", condition=""),
             "path 'package://bsf_vpr/data/nordland_subset100/summer_patchnorm.yaml' is '"),
            (dict(path="package://bsf_vpr/data/nordland_subset100/summer_patchnorm.yaml",
                  name="", condition=""), "outside the data directory"),
            (dict(path="package://no_such_package/x.yaml", name="", condition=""),
             "names package 'no_such_package', which ROS does not find"),
        ]
        for request, fragment in cases:
            r = self.load(**request)
            self.assertFalse(r.success, request)
            self.assertIn(fragment, r.message)
            self.assertEqual(self.names(), before)
        r = self.unload(name="no_such_set")
        self.assertFalse(r.success)
        self.assertIn("no_such_set", r.message)
        bad = Descriptor()
        bad.data = [1.0, 2.0]
        r = self.query(descriptor=bad)
        self.assertFalse(r.success)
        self.assertIn("dimension 2", r.message)
        self.assertEqual(self.names(), before)

    def test_bad_messages_are_dropped_and_the_next_is_processed(self):
        self.ensure_day_loaded()
        n_diag = len(self.diagnostics)
        for data in ([], [1.0] * 7, [float("nan")] * 4096):
            self.send(data)
        good = self.send(self.night[40])
        self.assertLessEqual(abs(self.belief_for(good).match - 40), 8)
        bad_stamps = range(good.secs - 3, good.secs)
        self.assertFalse(any(b.header.stamp.secs in bad_stamps for b in self.beliefs))

        def fusion_warned():
            for array in self.diagnostics[n_diag:]:
                for s in array.status:
                    if "fusion" in s.name and s.level == 1 and "dropped" in s.message:
                        return True
            return False
        wait_for(fusion_warned, 20, "a diagnostics warning about dropped descriptors")
        # The ingest node drops them too, and passes the good one on.
        for data in ([], [float("inf")] * 4096):
            self.send(data, self.external)
        good = self.send(self.night[41], self.external)
        self.assertLessEqual(abs(self.belief_for(good).match - 41), 8)

    def test_reconfigure_changes_the_belief(self):
        self.ensure_day_loaded()
        client = Client(NS + "fusion", timeout=30)
        try:
            client.update_configuration({"method": "nn:day", "gamma_fraction": 0.2})
            b = self.belief_for(self.send(self.night[60]))
            self.assertEqual(b.method, "nn:day")
            self.assertAlmostEqual(b.gamma, 0.2)
            self.assertEqual(len(b.posterior), 0)  # a distance method has no posterior
            config = client.update_configuration({"method": "nn:unknown"})
            self.assertEqual(config["method"], "nn:day")  # refused, previous kept
            client.update_configuration({"method": "bsf+filter+seq"})  # methods over time
            stamps = [self.send(self.night[i]) for i in range(70, 80)]
            b = self.belief_for(stamps[-1])
            self.assertEqual(b.method, "bsf+filter+seq")
            self.assertLessEqual(abs(b.match - 79), 8)
            self.assertEqual(len(b.posterior), 200)
        finally:
            client.update_configuration({"method": "bsf", "gamma_fraction": 0.04})
        b = self.belief_for(self.send(self.night[60]))
        self.assertEqual(b.method, "bsf")
        self.assertEqual(len(b.posterior), 200)

    def test_reconfiguring_the_threshold_keeps_the_filtered_belief(self):
        self.ensure_day_loaded()
        client = Client(NS + "fusion", timeout=30)
        try:
            client.update_configuration({"method": "bsf+filter"})
            stamps = [self.send(self.night[i]) for i in range(90, 96)]
            self.belief_for(stamps[-1])
            probe = Descriptor()
            probe.data = list(map(float, self.night[96]))
            before = self.query(descriptor=probe).belief.posterior
            client.update_configuration({"threshold": 0.95, "gamma_fraction": 0.05})
            after = self.query(descriptor=probe).belief.posterior
            np.testing.assert_allclose(after, before, rtol=1e-5)  # history kept
            client.update_configuration({"method": "bayes_full+filter"})
            fresh = self.query(descriptor=probe).belief.posterior
            self.assertFalse(np.allclose(fresh, before, rtol=1e-5))  # a new method: afresh
        finally:
            client.update_configuration({"method": "bsf", "threshold": 0.9,
                                         "gamma_fraction": 0.04})

    def test_tf_frame_for_an_accepted_match_with_a_pose(self):
        self.ensure_day_loaded()
        buffer = tf2_ros.Buffer()
        tf2_ros.TransformListener(buffer)
        n = len(self.matches)
        stamps = [self.send(self.night[i]) for i in range(100, 140)]
        self.belief_for(stamps[-1])
        wait_for(lambda: len(self.matches) > n, 20, "an accepted match")
        m = self.matches[n]
        self.assertTrue(m.has_pose)
        self.assertEqual(m.reference_set, "day")
        self.assertAlmostEqual(m.pose.position.x, float(m.place_id))

        def latest_is_a_new_match():
            # The latest transform; one of an earlier test's matches may still arrive first.
            if not buffer.can_transform("map", "vpr_place", rospy.Time(0)):
                return False
            t = buffer.lookup_transform("map", "vpr_place", rospy.Time(0))
            return any(abs(t.transform.translation.x - mm.place_id) < 1e-6
                       for mm in self.matches[n:])

        wait_for(latest_is_a_new_match, 20, "a map -> vpr_place transform at a new match")

    def test_services_and_reconfiguration_while_descriptors_stream(self):
        self.ensure_day_loaded()
        client = Client(NS + "fusion", timeout=30)
        n_before = len(self.beliefs)
        stop = threading.Event()

        def stream():
            i = 0
            while not stop.is_set() and not rospy.is_shutdown():
                self.send(self.night[i % 200])
                i += 1
                time.sleep(0.002)

        streamer = threading.Thread(target=stream)
        streamer.start()
        try:
            for k in range(10):
                self.assertTrue(self.load(path="day.npy", name="extra", condition="").success)
                client.update_configuration({"gamma_fraction": 0.01 * (k + 1),
                                             "method": "bayes_full" if k % 2 else "bsf"})
                self.assertTrue(self.unload(name="extra").success)
            # The loop may finish before many descriptors went out: stream on until enough
            # beliefs arrived (services do not wait for the descriptor queue).
            wait_for(lambda: len(self.beliefs) > n_before + 50, 20, "beliefs while streaming")
        finally:
            stop.set()
            streamer.join()
            client.update_configuration({"method": "bsf", "gamma_fraction": 0.04})
        # Every belief is internally consistent: no torn state between sets and selection.
        for b in self.beliefs[n_before:]:
            self.assertTrue(set(b.selected_sets) <= set(b.set_names), b.set_names)
            self.assertEqual(len(b.set_names), len(b.set_min_distances))
            self.assertIn(b.method, ("bsf", "bayes_full"))
            self.assertEqual(len(b.posterior), 200)
        self.assertEqual(self.names(), ["day"])
        last = self.belief_for(self.send(self.night[5]))
        self.assertLessEqual(abs(last.match - 5), 8)

    def test_selection_statistics_count_queries_per_set(self):
        self.ensure_day_loaded()
        self.stats(reset=True)
        stamps = [self.send(self.night[i]) for i in range(20)]
        self.belief_for(stamps[-1])
        r = self.stats(reset=False)
        self.assertEqual(r.queries, 20)
        day = [s for s in r.sets if s.name == "day"][0]
        self.assertEqual(day.selected, 20)  # the only set: always selected and closest
        self.assertAlmostEqual(day.mean_weight, 1.0)  # and the whole of the mixture
        self.assertEqual(list(self.belief_for(stamps[-1]).set_weights), [1.0])
        self.assertEqual(day.best, 20)
        self.assertEqual(day.supplied_match, 20)
        self.assertAlmostEqual(day.selected_fraction, 1.0)
        self.stats(reset=True)
        self.assertEqual(self.stats(reset=False).queries, 0)

    def test_recording_a_new_reference_set(self):
        self.ensure_day_loaded()
        r = self.stop(discard=False)
        self.assertFalse(r.success)
        self.assertIn("no recording", r.message)
        self.assertFalse(self.start(name="day", condition="").success)  # name taken
        self.assertFalse(self.start(name="../escape", condition="").success)
        r = self.start(name="tonight", condition="night")
        self.assertTrue(r.success, r.message)
        r = self.stop(discard=False)  # nothing arrived yet: the stop says so and ends it
        self.assertFalse(r.success)
        self.assertIn("received 0 descriptor(s)", r.message)
        self.assertIn("ended", r.message)
        self.assertEqual(r.num_received, 0)
        r = self.start(name="tonight", condition="night")
        self.assertTrue(r.success, r.message)
        stamps = [self.send(self.night[i]) for i in range(30)]
        self.belief_for(stamps[-1])  # processed in order: all 30 were recorded
        r = self.stop(discard=False)
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.num_descriptors, 30)
        self.assertEqual(r.num_received, 30)
        self.assertEqual(r.num_places, 30)
        self.assertIn("saved 30 place(s)", r.message)
        # A stop with nothing running reports no count of the recording that ended.
        r = self.stop(discard=False)
        self.assertFalse(r.success)
        self.assertEqual((r.num_received, r.num_descriptors), (0, 0), r.message)
        self.assertTrue(os.path.exists(os.path.join(self.data_dir, "tonight.yaml")))
        with open(os.path.join(self.data_dir, "tonight.yaml")) as f:
            npy = [l.split(":", 1)[1].strip() for l in f if l.startswith("descriptors:")][0]
        self.assertRegex(npy, r"^tonight\.[0-9a-f]{12}\.npy$")  # named by its content
        saved = np.load(os.path.join(self.data_dir, npy))
        np.testing.assert_allclose(saved, self.night[:30], rtol=1e-6)
        info = [s for s in self.list().sets if s.name == "tonight"][0]
        self.assertEqual(info.condition, "night")
        self.assertEqual(info.num_places, 30)
        self.assertTrue(self.unload(name="tonight").success)


    def test_a_failed_stop_leaves_a_pending_recording_that_takes_no_drive(self):
        self.ensure_day_loaded()
        with open(os.path.join(self.data_dir, "blocked2"), "w") as f:
            f.write("a file where a folder should be\n")
        self.assertTrue(self.start(name="blocked2/tonight", condition="").success)
        stamps = [self.send(self.night[i]) for i in range(8)]
        self.belief_for(stamps[-1])
        r = self.stop(discard=False)
        self.assertFalse(r.success)
        self.assertIn("received 8 descriptor(s), 8 kept", r.message)
        self.assertIn("discard", r.message)  # what to do
        self.assertEqual((r.num_received, r.num_descriptors), (8, 8))
        # The next drive is not added to it, and a new start says it is pending.
        stamps = [self.send(self.night[i]) for i in range(8, 14)]
        self.belief_for(stamps[-1])
        r = self.start(name="other", condition="")
        self.assertFalse(r.success)
        self.assertIn("pending", r.message)
        self.assertIn("discard: true", r.message)
        r = self.stop(discard=True)
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.num_descriptors, 8)
        os.remove(os.path.join(self.data_dir, "blocked2"))

    def test_reconfiguration_refuses_instead_of_clamping_and_answers_what_is_in_force(self):
        self.ensure_day_loaded()
        client = Client(NS + "fusion", timeout=30)
        try:
            for change in ({"gamma_fraction": -0.5}, {"sequence_length": 5000},
                           {"threshold": float("nan")}, {"method": "foo"}):
                config = client.update_configuration(change)
                self.assertEqual(config["gamma_fraction"], 0.04, change)  # not clamped to 0
                self.assertEqual(config["sequence_length"], 5, change)
                self.assertEqual(config["threshold"], 0.9, change)
                self.assertEqual(config["method"], "bsf", change)
            # threshold_kind alone: the threshold converted into the new kind's units.
            config = client.update_configuration({"threshold_kind": "log_odds"})
            self.assertEqual(config["threshold_kind"], "log_odds")
            self.assertAlmostEqual(config["threshold"], np.log(0.9 / 0.1), places=9)
            config = client.update_configuration({"threshold_kind": "probability"})
            self.assertAlmostEqual(config["threshold"], 0.9, places=9)
            config = client.update_configuration({"threshold": 8.0, "threshold_kind": "log_odds"})
            self.assertEqual((config["threshold"], config["threshold_kind"]), (8.0, "log_odds"))
        finally:
            client.update_configuration({"threshold": 0.9, "threshold_kind": "probability"})

    def test_the_pose_of_an_accepted_match_for_a_localiser(self):
        self.ensure_day_loaded()
        poses = []
        sub = rospy.Subscriber(NS + "pose", PoseWithCovarianceStamped, poses.append)
        # Connected before the queries go out: poses published before would be lost to it
        # (under load the connection takes a while).
        wait_for(lambda: sub.get_num_connections() > 0, 20, "the fusion node's pose publisher")
        n = len(self.matches)
        stamps = [self.send(self.night[i]) for i in range(100, 140)]
        self.belief_for(stamps[-1])
        wait_for(lambda: len(self.matches) > n and len(poses) > 0, 20, "a pose")
        sub.unregister()
        for p in poses:
            self.assertEqual(p.header.frame_id, "map")
            self.assertIn(p.header.stamp, stamps)
            belief = self.belief_for(p.header.stamp)
            self.assertTrue(belief.accepted)
            # The day set's places lie 1 m apart along x: the pose is near the match.
            self.assertLess(abs(p.pose.pose.position.x - belief.match), 10.0)
            c = p.pose.covariance
            self.assertTrue(all(np.isfinite(c)))
            # The floor: the robot anywhere along one place spacing, (1 m)^2 / 12.
            self.assertGreaterEqual(c[0], 1.0 / 12 - 1e-9)
            self.assertEqual(c[14], 1e6)  # z unknown
            # The chance the match is wrong, which the covariance does not carry, is the
            # match's: 1 - (1 - P(off)) m_near, at least P(off).
            match = [m for m in self.matches if m.header.stamp == p.header.stamp]
            self.assertEqual(len(match), 1)
            w = match[0].wrong_probability
            self.assertTrue(0.0 <= w <= 1.0, w)
            self.assertGreaterEqual(w, belief.off_map_probability - 1e-9)


    def test_a_publisher_of_the_other_descriptor_type_is_named_not_silently_unheard(self):
        # The ingest took bsf_vpr/Descriptor from the first publisher (self.external); roscpp
        # then refuses a Float32MultiArray publisher on the same topic: it is reported.
        # Another node, as on a robot (the master lists publishers per node).
        import subprocess
        since = rospy.Time.now()
        other = subprocess.Popen(["rostopic", "pub", "-r", "1", "__name:=array_publisher",
                                  "/vpr/descriptor", "std_msgs/Float32MultiArray",
                                  "{data: [1.0, 2.0]}"], stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL)
        try:
            def named():
                for array in list(self.diagnostics):
                    if array.header.stamp < since:
                        continue
                    for st in array.status:
                        if (st.name.endswith("descriptor_ingest") and st.level == 2 and
                                "not heard" in st.message and "/array_publisher" in st.message):
                            return True
                return False
            wait_for(named, 30, "descriptor_ingest to name the unheard publisher")
        finally:
            other.terminate()
            other.wait()


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_fusion_services", FusionServices)
