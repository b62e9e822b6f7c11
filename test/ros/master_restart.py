#!/usr/bin/python3
"""The nodes come back after a roscore restart (src/ros/common/master_watch.h).

Not a rostest (rostest owns its master): this script starts a roscore of its own on a free
port, runs fusion_node and descriptor_ingest_node on it, kills the roscore and starts a new
one on the same port, then checks that `rosnode list` shows both nodes again (the same
processes), that the fusion's services answer with the set it had loaded and its private
parameters are back, and that descriptors from a NEW publisher reach a NEW subscriber of
/bsf_vpr/belief. CMakeLists.txt runs it with catkin_run_tests_target; `--xml PATH` writes
its JUnit result there.

Usage: master_restart.py [--xml PATH]   (in a sourced workspace)
"""
import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import xmlrpc.client

import numpy as np

NS = "/bsf_vpr/"
NODES = (NS + "fusion", NS + "descriptor_ingest")
DIMENSION = 64
PLACES = 20
QUERIES = 30


def free_port():
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def wait_for(condition, timeout_s, what):
    """Polls `condition`; fails naming `what` (a string, or a function giving it then)."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("timed out after %.0f s waiting for %s"
                                 % (timeout_s, what() if callable(what) else what))
        time.sleep(0.1)


class Process:
    """A command in its own process group, its output in a file."""

    def __init__(self, tmp, name, command):
        self.name = name
        self.log_path = os.path.join(tmp, name + ".log")
        self.log = open(self.log_path, "w")
        self.proc = subprocess.Popen(command, stdout=self.log, stderr=subprocess.STDOUT,
                                     start_new_session=True)

    def output(self):
        with open(self.log_path, errors="replace") as f:
            return f.read()

    def stop(self, sig=signal.SIGINT):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, sig)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.log.close()


class MasterRestart(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="bsf_master_restart_")
        self.port = free_port()
        os.environ["ROS_MASTER_URI"] = "http://localhost:%d" % self.port
        os.environ["ROS_HOME"] = os.path.join(self.tmp, "ros_home")
        self.processes = []
        rng = np.random.default_rng(11)
        self.places = rng.standard_normal((PLACES, DIMENSION)).astype(np.float32)
        data = os.path.join(self.tmp, "data")
        os.makedirs(data)
        np.save(os.path.join(data, "route.npy"), self.places)
        with open(os.path.join(data, "route.yaml"), "w") as f:
            f.write("name: route\ndistance: cosine\ndescriptors: route.npy\n")
        self.data = data

    def tearDown(self):
        for p in reversed(self.processes):
            p.stop()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def start(self, name, command):
        p = Process(self.tmp, name, command)
        self.processes.append(p)
        return p

    def describe(self):
        return "\n".join("--- %s:\n%s" % (p.name, p.output()[-6000:]) for p in self.processes)

    def master(self):
        import rosgraph
        return rosgraph.Master("/master_restart_test")

    def master_up(self):
        try:
            self.master().getPid()
            return True
        except Exception:  # noqa: BLE001 - not up yet
            return False

    def registered_nodes(self):
        """The nodes the master knows (what `rosnode list` shows)."""
        try:
            state = self.master().getSystemState()
        except Exception:  # noqa: BLE001
            return set()
        return {n for part in state for _, nodes in part for n in nodes}

    def node_pid(self, name):
        uri = self.master().lookupNode(name)
        return xmlrpc.client.ServerProxy(uri).getPid("/master_restart_test")[2]

    def start_roscore(self, name):
        core = self.start(name, ["roscore", "-p", str(self.port)])
        wait_for(self.master_up, 60, "%s on port %d" % (name, self.port))
        return core

    def set_parameters(self):
        import rosgraph
        m = rosgraph.Master("/master_restart_test")
        m.setParam(NS + "fusion/reference_sets", [{"name": "route", "path": "route.yaml"}])
        m.setParam(NS + "fusion/distance", "cosine")
        m.setParam(NS + "fusion/data_directory", self.data)
        m.setParam(NS + "descriptor_ingest/input", "descriptor")

    def test_nodes_register_again_with_a_restarted_master(self):
        core = self.start_roscore("roscore_1")
        self.set_parameters()
        fusion = self.start("fusion", ["rosrun", "bsf_vpr", "fusion_node", "__ns:=/bsf_vpr"])
        ingest = self.start("descriptor_ingest", ["rosrun", "bsf_vpr", "descriptor_ingest_node",
                                          "__ns:=/bsf_vpr", "descriptor_in:=/test/descriptor"])
        wait_for(lambda: set(NODES) <= self.registered_nodes(), 120,
                 lambda: "both nodes on the first master:\n" + self.describe())
        wait_for(lambda: NS + "list_reference_sets" in
                 {s for s, _ in self.master().getSystemState()[2]}, 120,
                 lambda: "the fusion's services:\n" + self.describe())
        pids = {n: self.node_pid(n) for n in NODES}

        # The master goes, and a new one comes on the same port.
        core.stop()
        self.processes.remove(core)
        self.assertFalse(self.master_up())
        self.start_roscore("roscore_2")

        wait_for(lambda: set(NODES) <= self.registered_nodes(), 60,
                 lambda: "both nodes on the restarted master (rosnode list shows %s)\n%s"
                 % (sorted(self.registered_nodes()), self.describe()))
        for n in NODES:
            self.assertEqual(self.node_pid(n), pids[n], "%s restarted\n%s" % (n, self.describe()))
        for p in (fusion, ingest):
            wait_for(lambda: "master restarted: re-registered" in p.output(), 30,
                     lambda: "%s to log its re-registration\n%s" % (p.name, self.describe()))
            print("\n".join(l for l in p.output().splitlines() if "master restarted" in l))
        self.assertEqual(self.master().getParam(NS + "fusion/data_directory"), self.data)

        import rospy
        from bsf_vpr.msg import Belief, Descriptor
        from bsf_vpr.srv import ListReferenceSets
        rospy.init_node("master_restart_test", disable_signals=True)
        rospy.wait_for_service(NS + "list_reference_sets", timeout=60)
        listed = rospy.ServiceProxy(NS + "list_reference_sets", ListReferenceSets)()
        self.assertEqual([s.name for s in listed.sets], ["route"])

        # A new subscriber and a new publisher, both made after the restart.
        lock = threading.Lock()
        beliefs = {}

        def on_belief(msg):
            with lock:
                beliefs[msg.header.stamp] = msg

        sub = rospy.Subscriber(NS + "belief", Belief, on_belief, queue_size=100)
        pub = rospy.Publisher("/test/descriptor", Descriptor, queue_size=10)
        wait_for(lambda: sub.get_num_connections() > 0, 60,
                 "the fusion node's belief publisher to reach the new subscriber")
        wait_for(lambda: pub.get_num_connections() > 0, 60,
                 "descriptor_ingest to subscribe to the new publisher")
        for k in range(QUERIES):
            msg = Descriptor()
            msg.header.stamp = rospy.Time(1000 + k)
            msg.data = (self.places[k % PLACES] + 0.01).tolist()
            pub.publish(msg)
            stamp = msg.header.stamp
            wait_for(lambda: stamp in beliefs, 30,
                     lambda: "the belief of query %d of %d (%d arrived)\n%s"
                     % (k + 1, QUERIES, len(beliefs), self.describe()))
        with lock:
            matched = [beliefs[rospy.Time(1000 + k)].match for k in range(QUERIES)]
        self.assertEqual(matched, [k % PLACES for k in range(QUERIES)])
        rospy.signal_shutdown("done")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--xml", help="write the JUnit result here")
    args = parser.parse_args()
    suite = unittest.TestLoader().loadTestsFromTestCase(MasterRestart)
    if args.xml:
        from rosunit.xmlrunner import XMLTestRunner
        os.makedirs(os.path.dirname(os.path.abspath(args.xml)), exist_ok=True)
        with open(args.xml, "w") as stream:
            result = XMLTestRunner(stream=stream).run(suite)
    else:
        result = unittest.TextTestRunner(verbosity=2).run(suite)
    sys.exit(0 if result.wasSuccessful() else 1)


if __name__ == "__main__":
    main()
