#!/usr/bin/python3
"""rostest: the shipped config, launch and rviz files."""
import glob
import os
import subprocess
import sys
import tempfile
import unittest

import rosgraph
import rospy
import rostest
import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import scene_image, wait_for  # noqa: E402
from test_launch_files import load_launch  # noqa: E402

from bsf_vpr.srv import ListReferenceSets  # noqa: E402


class ConfigFiles(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_config_files")
        cls.pkg = rospy.get_param("~package_dir")
        cls.fixture = rospy.get_param("~fixture")

    def list_sets(self, ns):
        rospy.wait_for_service(ns + "/list_reference_sets", timeout=60)
        return rospy.ServiceProxy(ns + "/list_reference_sets", ListReferenceSets)()

    def test_every_fusion_config_starts_the_node(self):
        self.assertEqual(self.list_sets("/cfg_default").sets, [])
        self.assertEqual(self.list_sets("/cfg_cosine").sets, [])
        gp = self.list_sets("/cfg_gardens_point")
        self.assertEqual([s.name for s in gp.sets], ["day_left"])
        self.assertEqual(gp.num_places, 200)
        n100 = self.list_sets("/cfg_nordland100")
        self.assertEqual([s.name for s in n100.sets], ["summer", "fall"])
        self.assertEqual(n100.num_places, 100)
        nl = self.list_sets("/cfg_nordland")
        self.assertEqual([s.name for s in nl.sets], ["winter"])
        self.assertEqual(rospy.get_param("/cfg_cosine/fusion/distance"), "cosine")
        # Every documented key of the shipped defaults is a parameter the node knows: it
        # would have refused to start otherwise. Check the file lists them all.
        with open(os.path.join(self.pkg, "config", "fusion.yaml")) as f:
            keys = set(yaml.safe_load(f))
        self.assertIn("gamma_fraction", keys)
        self.assertIn("reference_sets", keys)

    def test_ingest_config_starts_the_node(self):
        master = rosgraph.Master("/test_config_files")
        wait_for(lambda: any(n == "/cfg_ingest/descriptor_ingest"
                             for n in master.getSystemState()[0][0][1] +
                             sum((p[1] for p in master.getSystemState()[0]), [])),
                 60, "descriptor_ingest to advertise its output")
        self.assertEqual(rospy.get_param("/cfg_ingest/descriptor_ingest/patch_size_px"), 8)

    def test_the_shard_nodelet_serves_its_sets_distances(self):
        from bsf_vpr.msg import Descriptor, ShardDistances, ShardInfo
        from bsf_vpr.srv import GetShardDistances
        info = rospy.wait_for_message("/cfg_shard/shard/shard_info", ShardInfo, timeout=60)
        self.assertEqual([s.name for s in info.sets], ["day_left"])
        self.assertEqual(len(info.sets[0].place_ids), 200)
        self.assertEqual(info.sets[0].dimension, 4096)
        self.assertEqual(info.distance, "cosine")
        rospy.wait_for_service("/cfg_shard/shard/get_distances", timeout=60)
        get = rospy.ServiceProxy("/cfg_shard/shard/get_distances", GetShardDistances)
        d = Descriptor()
        d.data = [1.0] * 4096
        r = get(descriptor=d).distances
        self.assertEqual(r.error, "")
        self.assertEqual((list(r.set_names), list(r.counts), len(r.distances)),
                         (["day_left"], [200], 200))
        self.assertEqual(r.fingerprints[0], info.sets[0].fingerprint)
        d.data = [1.0] * 10
        self.assertIn("dimension", get(descriptor=d).distances.error)
        # A descriptor of another type than the set's: computed, and warned about.
        from diagnostic_msgs.msg import DiagnosticArray
        warned = []
        sub = rospy.Subscriber("/diagnostics", DiagnosticArray, lambda a: warned.extend(
            st.message for st in a.status if "meet set 'day_left'" in st.message))
        answers = []
        answers_sub = rospy.Subscriber("/cfg_shard/shard/distances", ShardDistances,
                                       answers.append)
        pub = rospy.Publisher("/cfg_shard/descriptor", Descriptor, queue_size=1)
        d = Descriptor(descriptor_type="netvlad_4096", data=[1.0] * 4096)
        d.header.stamp = rospy.Time(5)
        wait_for(lambda: (pub.publish(d), bool(warned))[1], 30, "the shard's type warning")
        wait_for(lambda: bool(answers), 10, "the shard's distances")
        self.assertEqual(list(answers[0].counts), [200])
        for s in (sub, answers_sub, pub):
            s.unregister()

    def test_ingest_describes_images_with_hog_and_onnx(self):
        import numpy as np
        from sensor_msgs.msg import Image
        from bsf_vpr.msg import Descriptor
        for ns, dimension, kind in (("/cfg_ingest_hog", 756, "hog_64x32_c8_b9"),
                                    ("/cfg_ingest_onnx", 48, "onnx_model_48"),
                                    ("/cfg_ingest", 2048, "patchnorm_64x32_p8")):
            got = []
            sub = rospy.Subscriber(ns + "/descriptor", Descriptor, got.append)
            pub = rospy.Publisher(ns + "/image", Image, queue_size=1)
            wait_for(lambda: pub.get_num_connections() > 0, 30, ns + " to subscribe (lazily)")
            img = Image(height=32, width=64, encoding="rgb8", step=64 * 3)
            img.data = scene_image(32, 64)
            wait_for(lambda: (pub.publish(img), len(got) > 0)[1], 30, ns + " to describe an image")
            self.assertEqual(len(got[0].data), dimension, ns)
            self.assertEqual(got[0].descriptor_type, kind, ns)
            sub.unregister()
            pub.unregister()

    def test_every_launch_file_parses(self):
        launches = sorted(glob.glob(os.path.join(self.pkg, "launch", "*.launch")))
        self.assertGreaterEqual(len(launches), 2)
        for path in launches:
            args = {"bag": "/tmp/none.bag"} if path.endswith("replay.launch") else {}
            if path.endswith("benchmark_pipeline.launch"):
                args = {"data_directory": "/tmp"}
            if path.endswith("benchmark_sharded.launch"):
                args = {"data_directory": "/tmp", "sharded": "false"}
            shards = {"shard_%d_config" % k: os.path.join(
                self.pkg, "config", "benchmark_shard_%d.yaml" % k) for k in range(3)}
            if path.endswith("/sharded.launch"):
                args = shards
            config = load_launch(path, args)
            names = {n.name for n in config.nodes}
            self.assertIn("fusion", names, path)
            self.assertIn("descriptor_ingest", names, path)
            if path.endswith("/sharded.launch"):
                # Three shard processes, each on its own machine tag, and the combiner.
                self.assertLessEqual({"shard_0", "shard_1", "shard_2"}, names)
                self.assertEqual(config.params["/bsf_vpr/fusion/shards"].value,
                                 ["shard_0", "shard_1", "shard_2"])
                for node in config.nodes:
                    if node.name.startswith("shard_"):
                        self.assertEqual(node.machine_name, node.name + "_host")
                        self.assertEqual(node.type, "shard_node")
                self.assertEqual(config.params["/bsf_vpr/shard_1/reference_sets"].value,
                                 [{"name": "c1", "path": "c1.npy"}])
                # The combiner's match image: the camera, not the descriptors, whatever the
                # input (a descriptor topic read as images is a type clash).
                for given, image in (({}, "/camera/image_raw"),
                                     ({"input": "descriptor", "input_topic": "/d"},
                                      "/camera/image_raw"),
                                     ({"input_topic": "/cam"}, "/cam")):
                    parsed = load_launch(path, dict(args, **given))
                    fusion = [n for n in parsed.nodes if n.name == "fusion"][0]
                    self.assertIn(["image", image], [list(r) for r in fusion.remap_args], given)
            if "data_directory" not in args:  # not in the package's source folder
                ros_home = os.environ.get("ROS_HOME") or os.path.expanduser("~/.ros")
                self.assertEqual(config.params["/bsf_vpr/fusion/data_directory"].value,
                                 os.path.join(ros_home, "bsf_vpr"), path)
                # ROS_HOME moves it, as it moves ROS's own files.
                with tempfile.TemporaryDirectory() as tmp:
                    old_home = os.environ.get("ROS_HOME")
                    os.environ["ROS_HOME"] = tmp
                    try:
                        moved = load_launch(path, args)
                    finally:
                        if old_home is None:
                            del os.environ["ROS_HOME"]
                        else:
                            os.environ["ROS_HOME"] = old_home
                    self.assertEqual(moved.params["/bsf_vpr/fusion/data_directory"].value,
                                     os.path.join(tmp, "bsf_vpr"), path)
            # Every node starts from a clean private namespace: a key an earlier launch left
            # on the master (and the node would refuse) is cleared.
            for node in config.nodes:
                if node.package != "rosbag":
                    self.assertIn(node.namespace + node.name + "/", config.clear_params, path)
        for use_nodelets in ("true", "false"):
            config = load_launch(os.path.join(self.pkg, "launch", "bsf_vpr.launch"),
                                      {"use_nodelets": use_nodelets})
            types = {n.type for n in config.nodes}
            self.assertEqual("nodelet" in types, use_nodelets == "true")
            # A missing data_directory is created when the launch file is read.
            with tempfile.TemporaryDirectory() as tmp:
                wanted = os.path.join(tmp, "new", "data")
                config = load_launch(os.path.join(self.pkg, "launch", "bsf_vpr.launch"),
                                          {"use_nodelets": use_nodelets, "data_directory": wanted})
                self.assertEqual(config.params["/bsf_vpr/fusion/data_directory"].value, wanted)
                self.assertTrue(os.path.isdir(wanted))

    def fusion_params(self, launch, args):
        """The fusion node's private parameters as `launch` with `args` sets them."""
        params = load_launch(os.path.join(self.pkg, "launch", launch), args).params
        ns = "/bsf_vpr/fusion/"
        return {k[len(ns):]: p.value for k, p in params.items() if k.startswith(ns)}

    def test_config_and_extra_config_each_take_effect_alone(self):
        cosine = os.path.join(self.pkg, "config", "cosine.yaml")
        with tempfile.NamedTemporaryFile("w", suffix=".yaml") as mine:
            mine.write("distance: cosine\nmethod: med\n")
            mine.flush()
            for launch, args in (("bsf_vpr.launch", {}),
                                 ("bsf_vpr.launch", {"use_nodelets": "false"}),
                                 ("replay.launch", {"bag": "/tmp/none.bag"})):
                # config:= alone: that file only; the node's defaults fill in the rest.
                alone = self.fusion_params(launch, dict(args, config=mine.name))
                self.assertEqual(alone["distance"], "cosine", launch)
                self.assertEqual(alone["method"], "med", launch)
                self.assertNotIn("reference_sets", alone, launch)
                # extra_config:= alone: on top of the default config (config/fusion.yaml).
                extra = self.fusion_params(launch, dict(args, extra_config=cosine))
                self.assertEqual(extra["distance"], "cosine", launch)
                self.assertEqual(extra["method"], "bsf", launch)
                # Neither: config/fusion.yaml (distance "": the loaded sets' own).
                neither = self.fusion_params(launch, args)
                self.assertEqual(neither["distance"], "", launch)
                self.assertEqual(neither["method"], "bsf", launch)

    def test_rviz_file_shows_the_published_topics(self):
        with open(os.path.join(self.pkg, "rviz", "bsf_vpr.rviz")) as f:
            rviz = yaml.safe_load(f)
        displays = rviz["Visualization Manager"]["Displays"]
        topics = [d.get("Marker Topic") for d in displays]
        self.assertIn("/bsf_vpr/belief_markers", topics)
        self.assertIn("/bsf_vpr/fusion/match_image", [d.get("Image Topic") for d in displays])
        self.assertEqual(rviz["Visualization Manager"]["Global Options"]["Fixed Frame"], "map")
        # Names short enough for the Displays panel (they were cut: "Belief over places:
        # bars P(p...").
        for d in displays:
            self.assertLessEqual(len(d["Name"]), 24, d["Name"])
        self.assertIn("place_numbers", [d for d in displays
                                        if d.get("Marker Topic")][0]["Namespaces"])
        # The docks are laid out by panel name: the state must name the match image display.
        image = [d["Name"] for d in displays if d.get("Image Topic")][0]
        state = rviz["Window Geometry"]["QMainWindow State"]
        self.assertIn(image.encode("utf-16-be").hex(), str(state).lower())
        # The view follows the frame the fusion node broadcasts with its markers.
        with open(os.path.join(self.pkg, "config", "fusion.yaml")) as f:
            fusion = yaml.safe_load(f)
        view = rviz["Visualization Manager"]["Views"]["Current"]
        self.assertEqual(view["Target Frame"], fusion["view_frame"])
        # So does the grid: on a route larger than the view, the map's origin is out of it.
        grid = [d for d in displays if d["Class"] == "rviz/Grid"][0]
        self.assertEqual(grid["Reference Frame"], fusion["view_frame"])
        self.assertEqual(fusion["map_frame"], "map")

    def test_a_bad_parameter_stops_the_node_with_a_reason(self):
        cases = [(["_gama_fraction:=0.1"], "unknown parameter"),
                 (["_method:=seqslam"], "seqslam"),
                 (["_threshold:=1.5"], "(0, 1)"),
                 (["_carry_prior:=true"], "+filter"),
                 ([], "missing.npy")]
        rospy.set_param("/bad/bad4/reference_sets", [{"path": "missing.npy", "name": "m"}])
        # A combiner holds no sets of its own; shards is a list of names; a shard is no
        # combiner.
        cases += [([], "give reference_sets to the shards"), (["_shards:=shard_0"], "list"),
                  ([], "shards is the combiner's")]
        rospy.set_param("/bad/bad5/reference_sets", [{"path": "x.npy", "name": "x"}])
        rospy.set_param("/bad/bad5/shards", ["shard_0"])
        rospy.set_param("/bad/bad7/shards", ["shard_0"])
        for i, (params, fragment) in enumerate(cases):
            node = "shard_node" if i == 7 else "fusion_node"
            r = subprocess.run(["rosrun", "bsf_vpr", node, "__name:=bad%d" % i,
                                "__ns:=/bad"] + params,
                               capture_output=True, text=True, timeout=60, check=False)
            self.assertEqual(r.returncode, 1, params)
            self.assertIn(fragment, r.stdout + r.stderr, params)
        r = subprocess.run(["rosrun", "bsf_vpr", "descriptor_ingest_node", "__name:=bad_ingest",
                            "__ns:=/bad", "_image_descriptor:=onnx",
                            "_onnx_model:=/nonexistent/netvlad.onnx"],
                           capture_output=True, text=True, timeout=60, check=False)
        self.assertEqual(r.returncode, 1)
        self.assertIn("/nonexistent/netvlad.onnx", r.stdout + r.stderr)
        rospy.delete_param("/bad")  # the private parameters set for these nodes


    def test_start_up_messages_reach_rosout(self):
        """What a plain node logs while it starts (the sets loaded, why it cannot start)
        reaches /rosout, not only its console: it was logged before rosout had connected."""
        from rosgraph_msgs.msg import Log
        heard = []
        # rostest starts no rosout: this test runs its own, as roscore and roslaunch do.
        rosout = subprocess.Popen(["rosrun", "rosout", "rosout", "__name:=rosout"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.addCleanup(rosout.wait)
        self.addCleanup(rosout.terminate)
        sub = rospy.Subscriber("/rosout_agg", Log, heard.append, queue_size=100)
        wait_for(lambda: sub.get_num_connections() > 0, 30, "rosout's /rosout_agg")
        rospy.set_param("/startup/ready/reference_sets",
                        [{"name": "s", "path": os.path.join(
                            self.pkg, "data", "nordland_subset100", "summer_patchnorm.yaml")}])
        node = subprocess.Popen(["rosrun", "bsf_vpr", "fusion_node", "__name:=ready",
                                 "__ns:=/startup"], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        try:
            def said(name, fragment):
                return any(m.name == name and fragment in m.msg for m in list(heard))
            wait_for(lambda: said("/startup/ready", "fusion ready"), 60,
                     "the node's start-up message on /rosout_agg")
            self.assertTrue(said("/startup/ready", "loaded reference set 's'"))
            # A node that cannot start says why on /rosout too, then exits.
            r = subprocess.run(["rosrun", "bsf_vpr", "fusion_node", "__name:=refused",
                                "__ns:=/startup", "_gama_fraction:=0.1"],
                               capture_output=True, text=True, timeout=60, check=False)
            self.assertEqual(r.returncode, 1)
            wait_for(lambda: said("/startup/refused", "unknown parameter"), 30,
                     "the refusal on /rosout_agg")
        finally:
            node.terminate()
            node.wait()
            sub.unregister()
            rospy.delete_param("/startup")

if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_config_files", ConfigFiles)
