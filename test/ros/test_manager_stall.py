#!/usr/bin/python3
"""rostest: the default launch (launch/bsf_vpr.launch, nodelets in one manager) outlives a
stall of its nodelet manager longer than bond's heartbeat timeout (4 s), as a loaded machine
gives, and still ends when the manager truly dies (it is required)."""
import os
import signal
import struct
import sys
import tempfile
import threading
import time
import unittest
import xmlrpc.client

import numpy as np
import rosgraph
import rospy
import rostest
import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import wait_for, write_reference_set  # noqa: E402
from test_launch_files import Roslaunch  # noqa: E402

from bsf_vpr.msg import Belief, Descriptor  # noqa: E402

NS = "/bsf_vpr/"
MANAGER = NS + "bsf_vpr_manager"
LOADERS = (NS + "descriptor_ingest", NS + "fusion")
STALL_S = 8.0  # twice bond's DEFAULT_HEARTBEAT_TIMEOUT
DIMENSION = 64
PLACES = 20


def node_pid(name):
    """The process id of node `name` (its XML-RPC getPid), or None if it does not answer."""
    try:
        uri = rosgraph.Master("/test_manager_stall").lookupNode(name)
        code, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/test_manager_stall")
        return pid if code == 1 else None
    except Exception:  # noqa: BLE001 - not registered, or gone
        return None


def bond_status(buff):
    """(id, instance_id) of a serialised bond/Status (Header, id, instance_id, active, ...);
    bond's Python messages are not a dependency of this package."""
    def string_at(offset):
        n = struct.unpack_from("<I", buff, offset)[0]
        return buff[offset + 4:offset + 4 + n].decode(), offset + 4 + n
    _, offset = string_at(12)  # seq, stamp, then the header's frame_id
    bond_id, offset = string_at(offset)
    instance, _ = string_at(offset)
    return bond_id, instance


def bonded(pid):
    """Whether the nodelet loader `pid` bonds with its manager (no --no-bond)."""
    with open("/proc/%d/cmdline" % pid, "rb") as f:
        return b"--no-bond" not in f.read().split(b"\0")


def alive(pid):
    try:
        os.kill(pid, 0)
        return True
    except ProcessLookupError:
        return False


class ManagerStall(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_manager_stall")
        cls.tmp = tempfile.mkdtemp(prefix="bsf_manager_stall_")
        rng = np.random.default_rng(7)
        cls.places = rng.standard_normal((PLACES, DIMENSION)).astype(np.float32)
        write_reference_set(cls.tmp, "route", cls.places)
        cls.config = os.path.join(cls.tmp, "config.yaml")
        with open(cls.config, "w") as f:
            yaml.safe_dump({"reference_sets": [{"name": "route", "path": "route.yaml"}],
                            "distance": "cosine"}, f)
        cls.lock = threading.Lock()
        cls.arrivals = []  # monotonic receive time of each belief
        cls.sub = rospy.Subscriber(NS + "belief", Belief, cls.on_belief, queue_size=100)
        cls.pub = rospy.Publisher("/test/descriptor", Descriptor, queue_size=10)
        cls.heartbeats = {}  # bond id -> {instance id: heartbeats heard}
        cls.bond_sub = rospy.Subscriber(MANAGER + "/bond", rospy.AnyMsg, cls.on_bond,
                                        queue_size=100)

    @classmethod
    def on_bond(cls, msg):
        bond_id, instance = bond_status(msg._buff)
        with cls.lock:
            sides = cls.heartbeats.setdefault(bond_id, {})
            sides[instance] = sides.get(instance, 0) + 1

    def bonds_formed(self):
        """Bonds whose two sides have each sent 3 heartbeats (1 Hz): each hears the other."""
        with self.lock:
            return sum(1 for sides in self.heartbeats.values()
                       if len(sides) == 2 and min(sides.values()) >= 3)

    @classmethod
    def on_belief(cls, _):
        with cls.lock:
            cls.arrivals.append(time.monotonic())

    def beliefs_since(self, t):
        with self.lock:
            return sum(1 for a in self.arrivals if a > t)

    def publish_descriptors(self, stop):
        """A camera's stream: a descriptor near a place every 0.1 s until `stop` is set."""
        k = 0
        while not stop.is_set() and not rospy.is_shutdown():
            msg = Descriptor()
            msg.header.stamp = rospy.Time.now()
            msg.data = (self.places[k % PLACES] + 0.01).tolist()
            self.pub.publish(msg)
            k += 1
            stop.wait(0.1)

    def test_stalled_manager_keeps_the_pipeline_and_a_dead_one_ends_the_launch(self):
        # The default launch, as a user starts it: nodelets, no loader arguments.
        launch = Roslaunch("bsf_vpr.launch", {
            "config": self.config, "data_directory": self.tmp, "input": "descriptor",
            "input_topic": "/test/descriptor"})
        stop = threading.Event()
        camera = threading.Thread(target=self.publish_descriptors, args=(stop,), daemon=True)
        camera.start()
        manager_pid = None
        try:
            start = time.monotonic()
            launch.wait_until(lambda: self.beliefs_since(start) >= 5, 120, "the first beliefs")
            manager_pid = node_pid(MANAGER)
            loader_pids = [node_pid(n) for n in LOADERS]
            self.assertIsNotNone(manager_pid, launch.describe())
            self.assertNotIn(None, loader_pids, launch.describe())
            # Bonds (if the loaders make them) formed: a stall before would break none.
            expected_bonds = sum(bonded(pid) for pid in loader_pids)
            launch.wait_until(lambda: self.bonds_formed() >= expected_bonds, 120,
                              "%d bonds to form" % expected_bonds)

            # The manager stops (every nodelet with it) for longer than the bond's heartbeat
            # timeout, as a machine under load can stop it, and goes on.
            os.kill(manager_pid, signal.SIGSTOP)
            try:
                time.sleep(STALL_S)
            finally:
                os.kill(manager_pid, signal.SIGCONT)
            resumed = time.monotonic()

            # Beliefs flow again, and still 10 s after the manager went on (the backlog of
            # the stall comes at once; a bond breaks once the manager runs again), and the
            # launch and every loader are still there.
            launch.wait_until(lambda: self.beliefs_since(resumed + 10.0) >= 20, 120,
                              "20 beliefs from 10 s after the manager went on")
            self.assertIsNone(launch.proc.poll(), launch.describe())
            for name, pid in zip(LOADERS, loader_pids):
                self.assertTrue(alive(pid), "loader %s died: %s" % (name, launch.describe()))
                self.assertEqual(node_pid(name), pid, launch.describe())
            self.assertNotIn("Bond broken", launch.output())
            self.assertNotIn("has died", launch.output())

            # The real safety stays: a manager that dies ends the launch, loaders with it.
            os.kill(manager_pid, signal.SIGKILL)
            launch.wait(120)
            self.assertIn("REQUIRED process [bsf_vpr/bsf_vpr_manager-", launch.output())
            for name, pid in zip(LOADERS, loader_pids):
                wait_for(lambda: not alive(pid), 60, "loader %s to end" % name)
        finally:
            stop.set()
            camera.join()
            if manager_pid is not None and alive(manager_pid):
                os.kill(manager_pid, signal.SIGCONT)
            launch.stop()


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "manager_stall", ManagerStall)
