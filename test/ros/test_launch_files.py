#!/usr/bin/python3
"""rostest: launch/bsf_vpr.launch and launch/replay.launch, each started with roslaunch as a
subprocess on this test's master (one at a time, or two robots side by side), as a user
starts them; every launch file in launch/ read as roslaunch reads it, with paths that hold
quotes, spaces and $, and in another namespace (ns:=)."""
import contextlib
import glob
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import unittest

import rosbag
import rosgraph
import roslaunch.config
import roslaunch.xmlloader
import rosnode
import rospy
import rostest
import yaml
from dynamic_reconfigure.client import Client

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import service_is_up, wait_for  # noqa: E402

from bsf_vpr.srv import ListReferenceSets  # noqa: E402

NS = "/bsf_vpr/"
# An apostrophe, double quotes, spaces and a dollar sign: a path with any of them once broke
# every launch ("Invalid <param> tag: No closing quotation": roslaunch splits a command line
# with shlex, and the launch files quoted the path with '').
ODD = "it's \"odd\" $HOME"


class Roslaunch:
    """`roslaunch bsf_vpr LAUNCH ARGS` in the background, its output in a temporary file;
    `env` is added to this process's environment."""

    def __init__(self, launch, args, env=None):
        self.command = ["roslaunch", "bsf_vpr", launch] + ["%s:=%s" % kv for kv in args.items()]
        self.log = tempfile.NamedTemporaryFile(prefix="roslaunch_", suffix=".log")
        self.proc = subprocess.Popen(self.command, stdout=self.log, stderr=subprocess.STDOUT,
                                     env=dict(os.environ, **(env or {})))

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
def launched(launch, env=None, **args):
    """Runs a launch file for the duration of a `with` block."""
    process = Roslaunch(launch, args, env)
    try:
        yield process
    finally:
        process.stop()


@contextlib.contextmanager
def ros_home(path):
    """ROS_HOME set to `path` in this process (and the commands roslaunch runs) for a block."""
    old = os.environ.get("ROS_HOME")
    os.environ["ROS_HOME"] = path
    try:
        yield
    finally:
        if old is None:
            del os.environ["ROS_HOME"]
        else:
            os.environ["ROS_HOME"] = old


def load_launch(path, args):
    """The launch file as roslaunch reads it (its commands run, nothing starts)."""
    config = roslaunch.config.ROSLaunchConfig()
    loader = roslaunch.xmlloader.XmlLoader(resolve_anon=False)
    loader.load(path, config, argv=["roslaunch"] + ["%s:=%s" % kv for kv in args.items()],
                verbose=False)
    return config


def resolved(name, namespace):
    """`name` as a node in `namespace` resolves it."""
    return name if name.startswith("/") else rosgraph.names.ns_join(namespace, name)


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

    def check_pipeline(self, launch, sets, live, ns=NS):
        """Waits for both nodes in `ns`; checks the loaded sets and the live parameters
        (`live`, and config/fusion.yaml's values for the others)."""
        launch.wait_until(lambda: service_is_up(ns + "list_reference_sets"), 60, "fusion")
        launch.wait_until(lambda: advertised(ns + "descriptor"), 60, "descriptor_ingest")
        listed = rospy.ServiceProxy(ns + "list_reference_sets", ListReferenceSets)()
        self.assertEqual([s.name for s in listed.sets], sets, launch.describe())
        client = Client(ns + "fusion", timeout=30)
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


    def launch_cases(self, folder):
        """Every launch file in launch/ with the arguments it needs (paths below `folder`),
        and its variants: plain nodes, rviz, images, sharded or not."""
        shards = {"shard_%d_config" % k: os.path.join(self.pkg, "config",
                                                      "benchmark_shard_%d.yaml" % k)
                  for k in range(3)}
        replay = {"bag": os.path.join(folder, "in put.bag"),
                  "results": os.path.join(folder, "results %s.bag" % ODD)}
        cases = [("bsf_vpr.launch", {}),
                 ("bsf_vpr.launch", {"use_nodelets": "false", "rviz": "true"}),
                 ("replay.launch", replay),
                 ("replay.launch", dict(replay, use_nodelets="false")),
                 ("sharded.launch", dict(shards, rviz="true")),
                 ("benchmark_pipeline.launch", {"data_directory": folder}),
                 ("benchmark_pipeline.launch", {"data_directory": folder, "images": folder}),
                 ("benchmark_sharded.launch", {"data_directory": folder}),
                 ("benchmark_sharded.launch", {"data_directory": folder, "sharded": "false"})]
        shipped = {os.path.basename(p) for p in glob.glob(os.path.join(self.pkg, "launch",
                                                                        "*.launch"))}
        self.assertEqual({launch for launch, _ in cases}, shipped)
        return cases

    def load(self, launch, args):
        """load_launch of a shipped launch file; a failure names the file and its arguments."""
        try:
            return load_launch(os.path.join(self.pkg, "launch", launch), args)
        except Exception as e:  # noqa: BLE001 (whatever roslaunch raises fails the test)
            self.fail("roslaunch bsf_vpr %s %s: %s" % (launch, args, e))

    def test_every_launch_file_takes_paths_with_quotes_spaces_and_dollar_signs(self):
        # In ROS_HOME (the default data_directory) and in the paths given as arguments.
        home = os.path.join(self.tmp, "ros home " + ODD)
        folder = os.path.join(self.tmp, "data " + ODD)
        os.makedirs(folder)
        with ros_home(home):
            for launch, args in self.launch_cases(folder):
                where = "%s %s" % (launch, args)
                config = self.load(launch, args)
                wanted = args.get("data_directory", os.path.join(home, "bsf_vpr"))
                folders = {k: p.value for k, p in config.params.items()
                           if k.endswith("/data_directory")}
                self.assertTrue(folders, where)
                self.assertEqual(set(folders.values()), {wanted}, where)
                if launch in ("bsf_vpr.launch", "replay.launch"):
                    self.assertTrue(os.path.isdir(wanted), where)  # made by launch_path
                if launch == "replay.launch":
                    nodes = {n.name: n for n in config.nodes}
                    self.assertEqual(config.params["/replay_monitor/results"].value,
                                     args["results"], where)
                    self.assertEqual(config.params["/replay_monitor/bag"].value, args["bag"])
                    # Node arguments are split with shlex too: each path one word.
                    self.assertEqual(shlex.split(nodes["record_results"].args)[:2],
                                     ["-O", args["results"]], where)
                    self.assertEqual(shlex.split(nodes["play"].args)[-1], args["bag"], where)

    def test_ns_puts_every_name_of_every_launch_file_in_it(self):
        folder = os.path.join(self.tmp, "ns_data")
        os.makedirs(folder)
        # A replay's player, recorder and monitor stay at the root: the clock and
        # /use_sim_time are the master's, one replay at a time.
        at_root = {"record_results", "play", "replay_monitor"}
        for launch, args in self.launch_cases(folder):
            for ns, wanted in (("robot1", "/robot1/"), ("/fleet/robot2", "/fleet/robot2/"),
                               (None, NS)):
                given = dict(args, ns=ns) if ns else args
                where = "%s %s" % (launch, given)
                config = self.load(launch, given)
                root = at_root if launch == "replay.launch" else set()
                self.assertLessEqual(root, {n.name for n in config.nodes}, where)
                for node in config.nodes:
                    self.assertEqual(node.namespace, "/" if node.name in root else wanted,
                                     where + ": " + node.name)
                    for source, target in node.remap_args:
                        # Topics of the pipeline in its namespace; the camera's anywhere.
                        self.assertFalse(resolved(target, node.namespace).startswith(NS)
                                         and wanted != NS, "%s: %s remaps %s to %s"
                                         % (where, node.name, source, target))
                        if source.startswith(NS):  # rviz's absolute topics, taken along
                            self.assertEqual(resolved(target, node.namespace),
                                             wanted + source[len(NS):], where)
                    if node.name == "rviz":
                        self.assertEqual(len(node.remap_args), 2, where)
                for key, param in config.params.items():
                    if key not in ("/use_sim_time",) and not key.startswith("/replay_monitor/"):
                        self.assertTrue(key.startswith(wanted), "%s: %s" % (where, key))
                    if isinstance(param.value, str) and param.value.startswith("/"):
                        self.assertFalse(param.value.startswith(NS) and wanted != NS,
                                         "%s: %s is %s" % (where, key, param.value))
                if launch == "replay.launch":
                    nodes = {n.name: n for n in config.nodes}
                    self.assertEqual(shlex.split(nodes["record_results"].args)[2:],
                                     [wanted + "belief", wanted + "match", "/vpr/ground_truth",
                                      "/vpr/query_pose"], where)
                    self.assertEqual(config.params["/replay_monitor/belief_topic"].value,
                                     wanted + "belief", where)
                    self.assertIn("/replay_monitor/ready", nodes["play"].launch_prefix, where)
                shards = config.params.get(wanted + "fusion/shards")
                if launch == "sharded.launch" or (launch == "benchmark_sharded.launch"
                                                  and args.get("sharded") != "false"):
                    # Relative: the combiner resolves them in its namespace.
                    self.assertEqual(shards.value, ["shard_0", "shard_1", "shard_2"], where)
                    self.assertLessEqual({wanted + "shard_%d" % k for k in range(3)},
                                         {node.namespace + node.name for node in config.nodes})

    def test_two_robots_run_side_by_side_each_in_its_ns(self):
        # The second robot also reads its data_directory from a ROS_HOME with quotes, spaces
        # and $, as it starts for real.
        home = os.path.join(self.tmp, "robot1 home " + ODD)
        winter = self.write_config("winter_only.yaml", {
            "reference_sets": [{"name": "winter", "path": "winter.yaml"}], "distance": "cosine"})
        med = self.write_config("med.yaml", {"method": "med"})
        with launched("bsf_vpr.launch", config=winter, data_directory=self.fixture,
                      input="descriptor", input_topic="/test/descriptor") as first, \
                launched("bsf_vpr.launch", env={"ROS_HOME": home}, ns="robot1", config=med,
                         input="descriptor", input_topic="/test/robot1_descriptor") as second:
            self.check_pipeline(first, ["winter"], {"distance": "cosine"})
            self.check_pipeline(second, [], {"method": "med"}, ns="/robot1/")
            # Neither took the other's names: both still run (a node started under a name
            # already registered makes the other one leave), the first one still answers.
            self.check_pipeline(first, ["winter"], {"distance": "cosine"})
            self.assertIsNone(second.proc.poll(), second.describe())
            nodes = set(rosnode.get_node_names())
            for ns in (NS, "/robot1/"):
                self.assertLessEqual({ns + n for n in ("bsf_vpr_manager", "descriptor_ingest",
                                                        "fusion")}, nodes)
            self.assertEqual(rospy.get_param("/robot1/fusion/data_directory"),
                             os.path.join(home, "bsf_vpr"))
            self.assertTrue(os.path.isdir(os.path.join(home, "bsf_vpr")))
            self.assertTrue(advertised("/robot1/belief"))
        # A sharded map in its ns: the combiner finds its shards there (its list names them).
        one = self.write_config("shard_winter.yaml", {
            "reference_sets": [{"name": "winter", "path": "winter.yaml"}], "distance": "cosine"})
        empty = self.write_config("shard_empty.yaml", {"distance": "cosine"})
        with launched("sharded.launch", ns="robot2", data_directory=self.fixture,
                      shard_0_config=empty, shard_1_config=one, shard_2_config=empty,
                      input="descriptor", input_topic="/test/robot2_descriptor") as launch:
            service = "/robot2/list_reference_sets"
            launch.wait_until(lambda: service_is_up(service), 60, "the combiner")
            proxy = rospy.ServiceProxy(service, ListReferenceSets)
            launch.wait_until(lambda: proxy().sets, 60, "the combiner to take shard_1's set")
            self.assertEqual([(s.name, s.shard) for s in proxy().sets],
                             [("winter", "/robot2/shard_1")], launch.describe())


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_launch_files", LaunchFiles)
