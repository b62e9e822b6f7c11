#!/usr/bin/python3
"""rostest: the attacks of issue 10 against running nodes (see attacks.test).

Each attack must be refused with a message that names the problem, the nodes must keep
answering good queries, and nothing outside the data directory may be read or written."""
import hashlib
import os
import shutil
import signal
import sys
import threading
import time
import unittest
import xmlrpc.client

import numpy as np
import rosgraph
import rosnode
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from dynamic_reconfigure.client import Client
from sensor_msgs.msg import Image
from std_msgs.msg import Float32MultiArray, String

from bsf_vpr.msg import Belief, Descriptor, Match
from bsf_vpr.srv import ListReferenceSets, LoadReferenceSet
from rosgraph_msgs.msg import Log

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import (attach_fusion_services, run_tool, scene_image, wait_for,  # noqa: E402
                          write_reference_set)

NS = "/bsf_vpr/"


def tree_digest(folder):
    """Every entry below `folder` with the hash of its content (links by their target)."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = os.path.join(root, name)
            if os.path.islink(path):
                out[path] = "link:" + os.readlink(path)
            elif os.path.isfile(path):
                with open(path, "rb") as f:
                    out[path] = hashlib.sha256(f.read()).hexdigest()
            else:
                out[path] = "dir"
    return out


class Attacks(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_attacks")
        scratch = rospy.get_param("~scratch")
        cls.data = os.path.join(scratch, "data")
        cls.outside = os.path.join(scratch, "outside")
        # The node holds the data directory open: empty it, never replace it.
        wait_for(lambda: os.path.isdir(cls.data), 60, "the node to create its data directory")
        for entry in os.listdir(cls.data):
            path = os.path.join(cls.data, entry)
            if os.path.isdir(path) and not os.path.islink(path):
                shutil.rmtree(path)
            else:
                os.remove(path)
        shutil.rmtree(cls.outside, ignore_errors=True)
        os.makedirs(cls.outside)
        gp = rospy.get_param("~gardens_point_dir")
        cls.day = np.load(os.path.join(gp, "day_left.npy"))
        cls.night = np.load(os.path.join(gp, "night_right.npy"))
        write_reference_set(cls.data, "day", cls.day)
        with open(os.path.join(cls.data, "day.yaml"), "a") as f:
            f.write("descriptor_type: hdc_delf_4096\n")
        # Outside the data directory: a valid set that must never be loaded, a file that must
        # never be overwritten.
        write_reference_set(cls.outside, "secret", cls.day[:3])
        with open(os.path.join(cls.outside, "target.yaml"), "w") as f:
            f.write("precious\n")
        cls.outside_before = tree_digest(cls.outside)

        cls.beliefs, cls.matches, cls.diagnostics, cls.img_out = [], [], [], []
        rospy.Subscriber(NS + "belief", Belief, cls.beliefs.append)
        rospy.Subscriber(NS + "match", Match, cls.matches.append)
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls.diagnostics.append)
        rospy.Subscriber("/img/descriptor", Descriptor, cls.img_out.append)
        rospy.Subscriber("/imgwrong/descriptor", Descriptor, lambda m: None)
        rospy.Subscriber("/wrong/descriptor", Descriptor, lambda m: None)
        cls.raw = rospy.Publisher(NS + "descriptor", Descriptor, queue_size=100)
        cls.external = rospy.Publisher("/vpr/descriptor", Descriptor, queue_size=100)
        cls.array = rospy.Publisher("/vpr/array", Float32MultiArray, queue_size=10)
        cls.wrong = rospy.Publisher("/vpr/wrong", String, queue_size=10)
        cls.image = rospy.Publisher("/vpr/image", Image, queue_size=10)
        cls.not_image = rospy.Publisher("/vpr/not_an_image", String, queue_size=10)
        attach_fusion_services(cls, NS)
        wait_for(lambda: cls.raw.get_num_connections() > 0, 30, "fusion to subscribe")
        wait_for(lambda: cls.external.get_num_connections() > 0, 30, "ingest to subscribe")
        wait_for(lambda: cls.array.get_num_connections() > 0, 30, "array ingest to subscribe")
        wait_for(lambda: cls.image.get_num_connections() > 0, 30, "image ingest to subscribe")
        cls.stamp = 0

    def tearDown(self):
        # Whatever an attack did, nothing outside the data directory changed.
        self.assertEqual(tree_digest(self.outside), self.outside_before)

    # Helpers --------------------------------------------------------------------------
    def names(self):
        return [s.name for s in self.list().sets]

    def send(self, vector, publisher=None, descriptor_type=""):
        Attacks.stamp += 1
        msg = Descriptor()
        msg.header.stamp = rospy.Time(Attacks.stamp)
        msg.descriptor_type = descriptor_type
        msg.data = list(map(float, vector))
        (publisher or self.raw).publish(msg)
        return msg.header.stamp

    def belief_for(self, stamp, timeout=20):
        wait_for(lambda: any(b.header.stamp == stamp for b in self.beliefs), timeout, "a belief")
        return [b for b in self.beliefs if b.header.stamp == stamp][0]

    def still_serving(self, i=40):
        b = self.belief_for(self.send(self.night[i]))
        self.assertLessEqual(abs(b.match - i), 8)

    def ensure_day_loaded(self):
        if "day" not in self.names():
            r = self.load(path="day.yaml", name="", condition="")
            self.assertTrue(r.success, r.message)

    def diagnosed(self, since, level, fragment, node_fragment=""):
        """Waits for a status of `level` (or of any of the levels in a tuple) saying
        `fragment`, of a node whose name holds `node_fragment`."""
        levels = level if isinstance(level, tuple) else (level,)

        def found():
            for array in self.diagnostics[since:]:
                for s in array.status:
                    if (s.level in levels and fragment in s.message and
                            node_fragment in s.name):
                        return True
            return False
        wait_for(found, 20, "diagnostics level %s saying '%s'" % (level, fragment))

    def set_config(self, **config):
        Client(NS + "fusion", timeout=30).update_configuration(config)

    # Reads ------------------------------------------------------------------------------
    def test_loads_cannot_reach_outside_or_hang(self):
        self.ensure_day_loaded()
        before = self.names()
        secret = os.path.join(self.outside, "secret.npy")
        with open(os.path.join(self.data, "abs.yaml"), "w") as f:
            f.write("name: abs\ndescriptors: %s\n" % secret)
        with open(os.path.join(self.data, "up.yaml"), "w") as f:
            f.write("name: up\ndescriptors: ../outside/secret.npy\n")
        with open(os.path.join(self.data, "zero.yaml"), "w") as f:
            f.write("name: zero\ndescriptors: /dev/zero\n")
        os.symlink(secret, os.path.join(self.data, "link.npy"))
        os.symlink(self.outside, os.path.join(self.data, "outdir"))
        os.mkfifo(os.path.join(self.data, "x.npy"))
        cases = [("abs.yaml", "", "outside the data directory"),
                 ("up.yaml", "", "outside the data directory"),
                 ("zero.yaml", "", "outside the data directory"),
                 ("link.npy", "l", "links are not followed"),
                 ("outdir/secret.yaml", "", "links are not followed"),
                 ("x.npy", "fifo", "not a regular file"),
                 ("../outside/secret.yaml", "", "outside the data directory"),
                 (secret, "s", "outside the data directory"),
                 ("nothing.txt", "n", "No such file")]
        for path, name, fragment in cases:
            start = time.monotonic()
            r = self.load(path=path, name=name, condition="")
            self.assertFalse(r.success, path)
            self.assertIn(fragment, r.message, path)
            self.assertLess(time.monotonic() - start, 10, path)  # a FIFO used to hang forever
            self.assertEqual(self.names(), before)
        # An answer echoes a 10 MB request in a bounded message.
        r = self.load(path="p" * 10000000, name="", condition="")
        self.assertFalse(r.success)
        self.assertLess(len(r.message), 1000)
        self.still_serving()

    def test_set_names_and_poses_that_cannot_be_are_refused(self):
        # Issue 28: a set's name obeys one rule whatever names it; a NaN pose never loads.
        self.ensure_day_loaded()
        before = self.names()
        for bad, fragment in [("a\nb", "'a\\x0ab' holds a control character"),
                              ("n" * 5000, "(5000 characters) is too long")]:
            r = self.load(path="day.yaml", name=bad, condition="")
            self.assertFalse(r.success, repr(bad[:20]))
            self.assertIn(fragment, r.message)
            self.assertIn("1 to 128 bytes of printable UTF-8", r.message)
            self.assertLess(len(r.message), 1000)
        write_reference_set(self.data, "nan_pose", self.day[:3])
        with open(os.path.join(self.data, "nan_pose.yaml"), "a") as f:
            f.write("poses: [[0, 0, 0, 0], [.nan, 0, 0, 0], [2, 0, 0, 0]]\n")
        r = self.load(path="nan_pose.yaml", name="", condition="")
        self.assertFalse(r.success)
        self.assertIn("the pose of row 1 (place 1) has x = nan", r.message)
        self.assertEqual(self.names(), before)
        self.still_serving()

    def test_load_runs_beside_recognition(self):
        self.ensure_day_loaded()
        big = np.tile(self.day, (60, 1))  # 12000 x 4096 float32: 197 MB
        np.save(os.path.join(self.data, "big.npy"), big)
        del big
        arrivals, stop = [], threading.Event()

        def stream():
            i = 0
            while not stop.is_set():
                self.send(self.night[i % 200])
                i += 1
                time.sleep(0.01)
        n = len(self.beliefs)
        sub = rospy.Subscriber(NS + "belief", Belief, lambda m: arrivals.append(time.monotonic()))
        streamer = threading.Thread(target=stream)
        streamer.start()
        try:
            wait_for(lambda: len(self.beliefs) > n + 5, 20, "beliefs before the load")
            start = time.monotonic()
            r = self.load(path="big.npy", name="big", condition="")
            end = time.monotonic()
        finally:
            stop.set()
            streamer.join()
            sub.unregister()
        self.assertTrue(r.success, r.message)
        during = [t for t in arrivals if start < t < end]
        # The load takes a while; beliefs kept coming meanwhile (they used to stop).
        if end - start > 0.3:
            self.assertGreater(len(during), 0, "no belief during a %.2f s load" % (end - start))
        self.assertTrue(self.unload(name="big").success)
        os.remove(os.path.join(self.data, "big.npy"))

    # Writes -----------------------------------------------------------------------------
    def record(self, name, count=5, overwrite=False):
        r = self.start(name=name, condition="", overwrite=overwrite)
        self.assertTrue(r.success, r.message)
        stamps = [self.send(self.night[i]) for i in range(count)]
        self.belief_for(stamps[-1])

    def test_recording_names_are_checked_and_sets_on_disk_kept(self):
        self.ensure_day_loaded()
        for bad in ["", ".", "..", "a/../b", "../up", "a//b", "line\nbreak", "/abs",
                    "x" * 300]:
            r = self.start(name=bad, condition="", overwrite=False)
            self.assertFalse(r.success, repr(bad))
            self.assertLess(len(r.message), 1000)
        # The shipped-set attack: a name that exists on disk is refused, the files untouched.
        os.makedirs(os.path.join(self.data, "gp"), exist_ok=True)
        write_reference_set(os.path.join(self.data, "gp"), "day_left", self.day[:7])
        before = tree_digest(os.path.join(self.data, "gp"))
        r = self.start(name="gp/day_left", condition="", overwrite=False)
        self.assertFalse(r.success)
        self.assertIn("exists", r.message)
        self.assertEqual(tree_digest(os.path.join(self.data, "gp")), before)
        # Replacing it is possible when asked for.
        self.record("gp/day_left", count=4, overwrite=True)
        r = self.stop(discard=False)
        self.assertTrue(r.success, r.message)
        self.assertEqual(self.list().sets[-1].num_places, 4)
        self.assertTrue(self.unload(name="gp/day_left").success)
        gp = os.path.join(self.data, "gp")
        npys = sorted(f for f in os.listdir(gp) if f.endswith(".npy"))
        # The old set's day_left.npy was written by hand, not by a save: a file no save made
        # is never removed (issue 41 row 1), even when its YAML is replaced.
        self.assertEqual(len(npys), 2, npys)
        self.assertIn("day_left.npy", npys)
        first_save = [f for f in npys if f != "day_left.npy"][0]
        # Replaced again: the first save's own descriptors go with the YAML that named them.
        self.record("gp/day_left", count=3, overwrite=True)
        r = self.stop(discard=False)
        self.assertTrue(r.success, r.message)
        self.assertTrue(self.unload(name="gp/day_left").success)
        npys = sorted(f for f in os.listdir(gp) if f.endswith(".npy"))
        self.assertEqual(len(npys), 2, npys)
        self.assertNotIn(first_save, npys)
        self.assertIn("day_left.npy", npys)

    def test_a_link_swapped_in_before_the_save_is_not_followed(self):
        self.ensure_day_loaded()
        self.record("swap")
        os.symlink(os.path.join(self.outside, "target.yaml"), os.path.join(self.data, "swap.yaml"))
        r = self.stop(discard=False)
        self.assertFalse(r.success)  # it exists now, and overwrite was not asked for
        self.assertIn("kept", r.message)
        os.remove(os.path.join(self.data, "swap.yaml"))
        os.symlink(self.outside, os.path.join(self.data, "swapdir"))
        r = self.stop(discard=False)  # the recording survived the failed save
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.num_descriptors, 5)
        self.assertFalse(os.path.islink(os.path.join(self.data, "swap.yaml")))
        self.assertTrue(self.unload(name="swap").success)
        # A folder swapped for a link: refused, nothing written through it.
        r = self.start(name="swapdir/evil", condition="", overwrite=False)
        if r.success:
            stamps = [self.send(self.night[i]) for i in range(3)]
            self.belief_for(stamps[-1])
            r = self.stop(discard=False)
            self.assertFalse(r.success)
            self.assertTrue(self.stop(discard=True).success)

    def test_a_failed_save_keeps_the_recording(self):
        self.ensure_day_loaded()
        with open(os.path.join(self.data, "blocked"), "w") as f:
            f.write("a file where a folder should be\n")
        self.record("blocked/tonight", count=12)
        r = self.stop(discard=False)
        self.assertFalse(r.success)
        self.assertIn("kept", r.message)
        os.remove(os.path.join(self.data, "blocked"))
        r = self.stop(discard=False)
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.num_descriptors, 12)
        self.assertTrue(self.unload(name="blocked/tonight").success)

    # Messages ---------------------------------------------------------------------------
    def test_a_malformed_image_does_not_kill_the_ingest(self):
        n = len(self.img_out)
        bad = Image()
        bad.height, bad.width, bad.step, bad.encoding = 65537, 21845, 65536, "bgr8"
        bad.data = bytes(65536)  # 65537 x 65536 wraps to 65536 in 32 bits
        self.image.publish(bad)
        short = Image()
        short.height, short.width, short.step, short.encoding = 32, 64, 10, "mono8"
        short.data = bytes(320)
        self.image.publish(short)
        good = Image()
        good.height, good.width, good.step, good.encoding = 32, 64, 64 * 3, "bgr8"
        good.data = scene_image(32, 64)
        good.header.stamp = rospy.Time(777)
        self.image.publish(good)
        wait_for(lambda: any(d.header.stamp == rospy.Time(777) for d in self.img_out[n:]), 30,
                 "the good image's descriptor (the ingest survived)")
        self.assertEqual(len([d for d in self.img_out[n:] if d.header.stamp != rospy.Time(777)]),
                         0)

    def test_descriptors_lost_to_a_full_queue_are_counted(self):
        # A burst faster than a queue of one is emptied: the node is stopped while 200
        # descriptors are sent and continued, so that those its socket buffers hold arrive at
        # once. What its queue lost shows in the diagnostics (WARN), counted among the
        # dropped descriptors.
        pub = rospy.Publisher("/burst/descriptor", Descriptor, queue_size=1000)
        wait_for(lambda: pub.get_num_connections() > 0, 20, "the burst node")
        api = rosnode.get_api_uri(rosgraph.Master("/test_attacks"), "/burst/fusion",
                                  skip_cache=True)
        pid = xmlrpc.client.ServerProxy(api).getPid("/test_attacks")[2]
        # One first, heard: the gaps are counted from a publisher's previous message.
        first = Descriptor()
        first.header.stamp = rospy.Time(4999)
        first.data = list(map(float, self.night[0]))
        pub.publish(first)
        time.sleep(1)
        since = len(self.diagnostics)
        os.kill(pid, signal.SIGSTOP)
        try:
            for i in range(200):
                msg = Descriptor()
                msg.header.stamp = rospy.Time(5000 + i)
                msg.data = list(map(float, self.night[i % len(self.night)]))
                pub.publish(msg)
            time.sleep(2)  # on their way: in the sockets' buffers
        finally:
            os.kill(pid, signal.SIGCONT)
        self.diagnosed(since, 1, "to a full queue", "burst")

        def lost():
            total = 0
            for array in self.diagnostics[since:]:
                for s in array.status:
                    if "burst" in s.name:
                        values = {kv.key: kv.value for kv in s.values}
                        self.assertEqual(int(values["dropped descriptors"]),
                                         int(values["dropped: bad"]) +
                                         int(values["dropped: queue overflow"]))
                        total = int(values["dropped: queue overflow since start"])
            return total
        # How many the queue loses depends on how many reached the stopped node's socket (its
        # kernel buffers) against how fast it then works through the rest from the publisher:
        # 199 of 200 measured once, 6 another time, when queries had become faster. What must
        # hold: some were lost and counted, not all (the queue keeps the newest). The exact
        # count of gaps is test_sequence_gaps'.
        self.assertGreater(lost(), 0)
        self.assertLess(lost(), 200)
        pub.unregister()

    def test_huge_finite_descriptors_are_refused(self):
        self.ensure_day_loaded()
        n_match = len(self.matches)
        stamp = self.send(np.full(4096, 3.0e38))
        self.still_serving()
        self.assertFalse(any(b.header.stamp == stamp for b in self.beliefs))
        self.assertFalse(any(m.header.stamp == stamp for m in self.matches[n_match:]))

    def test_descriptors_without_information_are_dropped(self):
        # Issue 28: a black image describes as zeros, which a filter accepted on its history.
        self.ensure_day_loaded()
        since, n_out = len(self.diagnostics), len(self.img_out)
        black = Image()
        black.height, black.width, black.step, black.encoding = 32, 64, 64 * 3, "bgr8"
        black.data = bytes(32 * 64 * 3)
        black.header.stamp = rospy.Time(888)
        self.image.publish(black)
        self.diagnosed(since, (1, 2), "is uniform", "img")
        self.assertFalse(any(d.header.stamp == rospy.Time(888) for d in self.img_out[n_out:]))
        n_match = len(self.matches)
        stamp = self.send(np.zeros(4096))
        # A warning, or an error if nothing else came in the diagnostics' period.
        self.diagnosed(since, (1, 2), "all zeros: it carries no information", "fusion")
        self.still_serving()
        self.assertFalse(any(b.header.stamp == stamp for b in self.beliefs))
        self.assertFalse(any(m.header.stamp == stamp for m in self.matches[n_match:]))

    def test_float32_multi_array_descriptors_are_accepted(self):
        self.ensure_day_loaded()
        n = len(self.beliefs)
        msg = Float32MultiArray()
        msg.data = list(map(float, self.night[50]))
        self.array.publish(msg)
        wait_for(lambda: len(self.beliefs) > n, 20, "a belief from a Float32MultiArray")
        self.assertLessEqual(abs(self.beliefs[-1].match - 50), 8)

    def test_other_message_types_are_reported(self):
        since = len(self.diagnostics)
        self.wrong.publish(String(data="not a descriptor"))
        self.diagnosed(since, 2, "std_msgs/String", "wrong_ingest")
        self.not_image.publish(String(data="not an image"))
        self.diagnosed(since, 2, "std_msgs/String", "imgwrong")

    def test_a_descriptor_type_unlike_the_sets_is_warned_about(self):
        self.ensure_day_loaded()
        since = len(self.diagnostics)
        self.belief_for(self.send(self.night[3], descriptor_type="patchnorm_64x32_p8"))
        self.diagnosed(since, 1, "patchnorm_64x32_p8")

    # Gating -----------------------------------------------------------------------------
    def test_every_method_is_gated(self):
        self.ensure_day_loaded()
        try:
            # A distance method accepts nothing until max_match_distance allows it.
            self.set_config(method="med", max_match_distance=0.0)
            n = len(self.matches)
            self.belief_for(self.send(self.night[10]))
            self.belief_for(self.send(self.night[11]))
            self.assertEqual(len(self.matches), n)
            self.set_config(max_match_distance=2.0)  # cosine distances lie in [0, 2]
            stamp = self.send(self.night[12])
            wait_for(lambda: any(m.header.stamp == stamp for m in self.matches), 20, "a match")
            # +seq at h = 0.99: queries of random noise are not accepted.
            self.set_config(method="bsf+seq", threshold=0.99, threshold_kind="probability")
            rng = np.random.default_rng(3)
            n = len(self.matches)
            # One at a time, each belief awaited: a burst of 15 can overflow the node's queue
            # on a loaded machine, and a dropped query has no belief to wait for.
            beliefs = [self.belief_for(self.send(rng.standard_normal(4096))) for _ in range(15)]
            self.assertTrue(all(np.isfinite(b.confidence) for b in beliefs))
            self.assertLessEqual(sum(b.accepted for b in beliefs), 1)
            self.assertLessEqual(len(self.matches) - n, 1)
        finally:
            self.set_config(method="bsf", max_match_distance=0.0, threshold=0.9)

    def test_unloading_a_set_the_method_needs_is_refused(self):
        self.ensure_day_loaded()
        try:
            for method in ["nn:day+seq", "bayes:day+filter"]:
                self.set_config(method=method)
                r = self.unload(name="day")
                self.assertFalse(r.success, method)
                self.assertIn("used by method", r.message)
                self.still_serving(30)
        finally:
            self.set_config(method="bsf")

    def test_a_recording_of_another_dimension_does_not_stop_recognition(self):
        for name in self.names():
            self.assertTrue(self.unload(name=name).success)
        r = self.start(name="odd", condition="", overwrite=False)
        self.assertTrue(r.success, r.message)
        try:
            self.send([1.0] * 5)  # the recording takes dimension 5
            self.ensure_day_loaded()
            self.still_serving()  # 4096-d queries are recognised though the recording refuses them
        finally:
            self.assertTrue(self.stop(discard=True).success)

    def test_a_mapped_file_rewritten_in_place_is_dropped_and_never_used(self):
        """Found attacking the node: with memory_map, `cp other.npy mapped.npy` switched the
        live map to the new rows silently, bytes written in place gave wrong accepted matches,
        and `truncate` killed the node (SIGBUS). Each, while descriptors stream at 20 Hz: no
        descriptor sent after the change is decided with the set, the set is unloaded, the
        log and the diagnostics name it and its file, and the node goes on serving."""
        data = os.path.join(rospy.get_param("~scratch"), "mapped")
        wait_for(lambda: os.path.isdir(data), 60, "the mapped node's data directory")
        rng = np.random.default_rng(5)
        rows = rng.standard_normal((300, 64)).astype(np.float32)
        other = rng.standard_normal((300, 64)).astype(np.float32)
        load = rospy.ServiceProxy("/mapped/load_reference_set", LoadReferenceSet)
        listing = rospy.ServiceProxy("/mapped/list_reference_sets", ListReferenceSets)
        publisher = rospy.Publisher("/mapped/descriptor", Descriptor, queue_size=100)
        beliefs, logs = [], []
        subs = [rospy.Subscriber("/mapped/belief", Belief, beliefs.append),
                rospy.Subscriber("/rosout", Log, logs.append),
                rospy.Subscriber("/rosout_agg", Log, logs.append)]
        wait_for(lambda: publisher.get_num_connections() > 0, 30, "the mapped node")
        write_reference_set(data, "raw", rows)
        write_reference_set(data, "raw_other", other)
        run_tool("bsf_store_set", "--set", os.path.join(data, "raw_other.yaml"),
                 "--out", os.path.join(data, "other_int8.yaml"))
        other_npy = [f for f in os.listdir(data) if f.startswith("other_int8.int8.")][0]
        # A set that stays, so that beliefs go on once the attacked one is gone.
        r = load(path="other_int8.yaml", name="stays", condition="")
        self.assertTrue(r.success, r.message)
        try:
            for k, how in enumerate(("copied over", "bytes in place", "truncated")):
                name = "m%d" % k
                run_tool("bsf_store_set", "--set", os.path.join(data, "raw.yaml"),
                         "--out", os.path.join(data, name + ".yaml"))
                npy = os.path.join(data, [f for f in os.listdir(data)
                                          if f.startswith(name + ".int8.")][0])
                r = load(path=name + ".yaml", name=name, condition="")
                self.assertTrue(r.success, r.message)
                stop, changed_at = threading.Event(), {}
                sent = []

                def stream():
                    i = 0
                    while not stop.is_set():
                        msg = Descriptor()
                        msg.header.stamp = rospy.Time.now()
                        msg.data = list(map(float, rows[i % 300] + 0.05 * rng.standard_normal(64)))
                        sent.append(msg.header.stamp)
                        publisher.publish(msg)
                        i += 1
                        time.sleep(0.05)
                streamer = threading.Thread(target=stream)
                streamer.start()
                try:
                    wait_for(lambda: sum(name in b.used_sets for b in beliefs) >= 10, 20,
                             "beliefs using '%s'" % name)
                    since = len(self.diagnostics)
                    if how == "copied over":
                        shutil.copyfile(os.path.join(data, other_npy), npy)  # same size
                    elif how == "bytes in place":
                        with open(npy, "r+b") as f:
                            f.seek(os.path.getsize(npy) // 2)
                            f.write(os.urandom(4096))
                    else:
                        os.truncate(npy, 100)
                    changed_at["t"] = rospy.Time.now()
                    wait_for(lambda: sum(b.header.stamp > changed_at["t"] for b in beliefs) >= 10,
                             20, "beliefs after the change (%s)" % how)
                finally:
                    stop.set()
                    streamer.join()
                after = [b for b in beliefs if b.header.stamp > changed_at["t"]]
                self.assertTrue(after)
                for b in after:
                    self.assertNotIn(name, b.used_sets, "%s: a belief used the changed rows" % how)
                    self.assertNotIn(name, b.selected_sets, how)
                self.assertNotIn(name, [s.name for s in listing().sets], how)
                self.diagnosed(since, 1, "'%s' was unloaded" % name, "mapped")
                wait_for(lambda: any("'%s' unloaded" % name in m.msg and
                                     os.path.basename(npy) in m.msg for m in logs), 10,
                         "an error naming '%s' and its file (heard: %s)" % (
                             name, [m.msg[:80] for m in logs[-5:]]))
                # Still serving: another set loads and answers.
                r = load(path="other_int8.yaml", name="after_" + name, condition="")
                self.assertTrue(r.success, r.message)
                self.assertIn("after_" + name, [s.name for s in listing().sets])
                print("%s: %d beliefs after the change, none with the set; %s" % (
                    how, len(after), [m.msg for m in logs if name in m.msg][:1]))
        finally:
            for sub in subs:
                sub.unregister()

    def test_distance_defaults_to_the_sets_own(self):
        # The gp node was started without a distance and with a cosine set.
        since = len(self.diagnostics)

        def found():
            for array in self.diagnostics[since:]:
                for s in array.status:
                    if "gp" in s.name or "/gp/" in s.hardware_id:
                        for kv in s.values:
                            if kv.key == "distance":
                                return kv.value
            return None
        wait_for(lambda: found() is not None, 30, "diagnostics of the gp node")
        self.assertEqual(found(), "cosine")
        # The empty node without a distance takes the first loaded set's (a cosine set).
        load = rospy.ServiceProxy("/empty/load_reference_set", LoadReferenceSet)
        rospy.wait_for_service("/empty/load_reference_set", timeout=60)
        r = load(path="gardens_point_hdc_delf/day_left.yaml", name="", condition="")
        self.assertTrue(r.success, r.message)


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_attacks", Attacks)
