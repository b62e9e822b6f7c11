#!/usr/bin/python3
"""rostest: launch/bsf_vpr.launch and launch/replay.launch, each started with roslaunch as a
subprocess on this test's master (one at a time), as a user starts them."""
import contextlib
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import unittest

import rosbag
import rosgraph
import rospy
import rostest
import yaml
from dynamic_reconfigure.client import Client

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import service_is_up, wait_for  # noqa: E402

from bsf_vpr.srv import ListReferenceSets  # noqa: E402

NS = "/bsf_vpr/"


class Roslaunch:
    """`roslaunch bsf_vpr LAUNCH ARGS` in the background, its output in a temporary file."""

    def __init__(self, launch, args):
        self.command = ["roslaunch", "bsf_vpr", launch] + ["%s:=%s" % kv for kv in args.items()]
        self.log = tempfile.NamedTemporaryFile(prefix="roslaunch_", suffix=".log")
        self.proc = subprocess.Popen(self.command, stdout=self.log, stderr=subprocess.STDOUT)

    def output(self):
        with open(self.log.name, errors="replace") as f:
            return f.read()

    def describe(self):
        return "%s\n--- its output:\n%s" % (" ".join(self.command), self.output())

    def wait(self, timeout_s):
        """Waits for roslaunch to end by itself; returns its exit status."""
        try:
            return self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.stop()
            raise AssertionError("roslaunch did not end within %.0f s: %s" %
                                 (timeout_s, self.describe()))

    def stop(self):
        """Ends it as Ctrl-C does and waits until its nodes are gone."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def wait_until(self, condition, timeout_s, what):
        """Waits for `condition` while roslaunch is running; fails with its output if it ends."""
        def check():
            if self.proc.poll() is not None:
                raise AssertionError("roslaunch ended (exit status %d) before %s: %s" %
                                     (self.proc.returncode, what, self.describe()))
            return condition()
        wait_for(check, timeout_s, what)


@contextlib.contextmanager
def launched(launch, **args):
    """Runs a launch file for the duration of a `with` block."""
    process = Roslaunch(launch, args)
    try:
        yield process
    finally:
        process.stop()


def advertised(topic):
    """True if some node publishes `topic` (a nodelet registers as its manager)."""
    publishers = rosgraph.Master("/test_launch_files").getSystemState()[0]
    return any(t == topic and nodes for t, nodes in publishers)


class LaunchFiles(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_launch_files")
        cls.pkg = rospy.get_param("~package_dir")
        cls.fixture = rospy.get_param("~fixture")  # winter.yaml: Nordland winter, cosine
        cls.tmp = tempfile.mkdtemp(prefix="bsf_launch_files_")
        with open(os.path.join(cls.pkg, "config", "fusion.yaml")) as f:
            cls.defaults = yaml.safe_load(f)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def write_config(self, name, params):
        path = os.path.join(self.tmp, name)
        with open(path, "w") as f:
            yaml.safe_dump(params, f)
        return path

    def check_pipeline(self, launch, sets, live):
        """Waits for both nodes; checks the loaded sets and the live parameters (`live`, and
        config/fusion.yaml's values for the others)."""
        launch.wait_until(lambda: service_is_up(NS + "list_reference_sets"), 60, "fusion")
        launch.wait_until(lambda: advertised(NS + "descriptor"), 60, "descriptor_ingest")
        listed = rospy.ServiceProxy(NS + "list_reference_sets", ListReferenceSets)()
        self.assertEqual([s.name for s in listed.sets], sets, launch.describe())
        client = Client(NS + "fusion", timeout=30)
        try:
            config = client.get_configuration(timeout=30)
        finally:
            client.close()
        for key in ("method", "gamma_fraction", "selection", "likelihood", "threshold",
                    "threshold_kind", "max_match_distance", "filter_step_mean_places",
                    "filter_step_std_places", "relocalization_probability"):
            expected = live.get(key, self.defaults[key])
            self.assertEqual(config[key], expected, "%s: %s" % (key, launch.describe()))
        self.assertIsNone(launch.proc.poll(), launch.describe())  # nothing refused to start

    def test_config_and_extra_config_take_effect_alone_and_old_parameters_are_cleared(self):
        # config:= alone: before, the default extra_config (all of config/fusion.yaml) was
        # loaded on top and put back reference_sets: [] and distance: euclidean. The winter
        # set says cosine: it loads only if distance: cosine took effect.
        mine = {"reference_sets": [{"name": "winter", "path": "winter.yaml"}],
                "distance": "cosine", "method": "med", "gamma_fraction": 0.1}
        mine_path = self.write_config("mine.yaml", mine)
        other_path = self.write_config("other.yaml", {"method": "bayes_full"})
        common = {"data_directory": self.fixture, "input": "descriptor",
                  "input_topic": "/test/descriptor"}
        for use_nodelets in ("true", "false"):
            # Misspelt keys an earlier launch left on the master: the nodes refuse unknown
            # keys, so they must not see them.
            rospy.set_param(NS + "fusion/gama_fraction", 0.1)
            rospy.set_param(NS + "descriptor_ingest/patch_sise_px", 8)
            with launched("bsf_vpr.launch", config=mine_path, use_nodelets=use_nodelets,
                          **common) as launch:
                self.check_pipeline(launch, ["winter"], mine)
                self.assertFalse(rospy.has_param(NS + "fusion/gama_fraction"))
                self.assertFalse(rospy.has_param(NS + "descriptor_ingest/patch_sise_px"))
            # The next launch does not inherit this one's reference sets, distance, method
            # or gamma (still on the master after roslaunch ends).
            self.assertEqual(rospy.get_param(NS + "fusion/method"), "med")
            with launched("bsf_vpr.launch", config=other_path, use_nodelets=use_nodelets,
                          **common) as launch:
                self.check_pipeline(launch, [], {"method": "bayes_full"})
        # extra_config:= alone, as README's robot command gives it: on top of fusion.yaml.
        gardens_point = os.path.join(self.pkg, "config", "gardens_point.yaml")
        with launched("bsf_vpr.launch", input_topic="/camera/image_raw", extra_config=gardens_point,
                      data_directory=os.path.join(self.pkg, "data")) as launch:
            self.check_pipeline(launch, ["day_left"], {})

    def make_bag(self):
        """A bag of the first 5 Nordland summer frames with their ground truth."""
        path = os.path.join(self.tmp, "in", "tiny.bag")
        r = subprocess.run(["rosrun", "bsf_vpr", "bsf_make_bag", "--images",
                            os.path.join(self.pkg, "data", "nordland_64x32", "summer"),
                            "--limit", "5", "--tolerance", "2", "--num-places", "1500",
                            "--rate", "10", "--out", path],
                           capture_output=True, text=True, timeout=60, check=False)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        return path

    def replay(self, results, **extra):
        args = {"bag": self.bag, "results": results, "data_directory": self.fixture,
                "extra_config": os.path.join(self.pkg, "config", "nordland.yaml"),
                "rate": "10"}
        args.update(extra)
        return Roslaunch("replay.launch", args)

    def test_replay_runs_on_sim_time_leaves_it_unset_and_fails_without_results(self):
        self.bag = self.make_bag()
        self.assertFalse(rospy.has_param("/use_sim_time"))
        out = os.path.join(self.tmp, "out")
        os.makedirs(out)

        # A results path that cannot be written stops roslaunch before anything runs.
        with open(os.path.join(self.tmp, "a_file"), "w") as f:
            f.write("x")
        for results in (os.path.join(self.tmp, "missing", "results.bag"),
                        os.path.join(self.tmp, "a_file", "results.bag"), out):
            launch = self.replay(results)
            self.assertEqual(launch.wait(60), 1, launch.describe())
            self.assertIn("launch_path: cannot write '%s'" % results, launch.output())
            self.assertNotIn("process[", launch.output())  # no node was started
        self.assertFalse(rospy.has_param("/use_sim_time"))

        # A recorder that cannot write once running (the file it writes is taken by a
        # folder): the monitor ends the replay with exit code 1 and says why.
        os.makedirs(os.path.join(out, "blocked.bag.active"))
        launch = self.replay(os.path.join(out, "blocked.bag"), recorder_timeout_s="5")
        launch.wait(120)  # roslaunch's own status is 0 whatever its nodes do
        self.assertIn("replay_monitor: the recorder is not writing the results bag",
                      launch.output(), launch.describe())
        self.assertRegex(launch.output(), r"REQUIRED process \[replay_monitor-\d+\] has died!\n"
                         r"process has died \[pid \d+, exit code 1", launch.describe())
        self.assertFalse(os.path.isfile(os.path.join(out, "blocked.bag")))
        self.assertFalse(rospy.has_param("/use_sim_time"))

        # A replay that works: every belief recorded, on the bag's (simulated) time, and
        # /use_sim_time deleted at the end.
        results = os.path.join(out, "results.bag")
        launch = self.replay(results)
        self.assertEqual(launch.wait(120), 0, launch.describe())
        self.assertIn("replay_monitor: done, 5 beliefs", launch.output(), launch.describe())
        with rosbag.Bag(results) as bag:
            times = [t.to_sec() for _, _, t in bag.read_messages(topics=["/bsf_vpr/belief"])]
        self.assertEqual(len(times), 5)
        # bsf_make_bag stamps the queries from 1000 s on; wall-clock times are ~1.7e9 s.
        self.assertTrue(all(1000 <= t < 1100 for t in times), times)
        self.assertFalse(rospy.has_param("/use_sim_time"))


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_launch_files", LaunchFiles)
