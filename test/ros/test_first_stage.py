#!/usr/bin/python3
"""rostest: the fusion node with the pca first stage, on Gardens Point (real HDC-DELF)."""
import os
import re
import shutil
import sys
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray

from bsf_vpr.msg import Descriptor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import attach_fusion_services, wait_for, write_reference_set  # noqa: E402

NS = "/bsf_vpr/"


class FirstStage(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_first_stage")
        cls.data_dir = rospy.get_param("~data_dir")
        shutil.rmtree(cls.data_dir, ignore_errors=True)
        gp = rospy.get_param("~gardens_point_dir")
        cls.day = np.load(os.path.join(gp, "day_left.npy"))
        cls.night = np.load(os.path.join(gp, "night_right.npy"))
        write_reference_set(cls.data_dir, "day", cls.day)
        cls.diagnostics = []
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls.diagnostics.append)
        attach_fusion_services(cls, NS)

    def matches(self, queries):
        out = []
        for q in queries:
            d = Descriptor()
            d.data = list(map(float, self.night[q]))
            r = self.query(descriptor=d)
            self.assertTrue(r.success, r.message)
            out.append(r.belief.match)
        return out

    def index_rows_after(self, stamp, rows):
        """Waits for diagnostics published after `stamp` to report an index of `rows` rows
        (it is built in the background after each change of sets; meanwhile they say it is
        building) and checks what they say of it; fails the test if none does within 20 s."""
        found = []

        def reported():
            for array in self.diagnostics:
                if array.header.stamp <= stamp:
                    continue
                for status in array.status:
                    for kv in status.values:
                        if kv.key == "first stage" and " of %d rows" % rows in kv.value:
                            found.append(kv.value)
                            return True
            return False
        wait_for(reported, 20, "diagnostics reporting an index of %d rows" % rows)
        m = re.match(r"pca: 64 dimensions keeping (\d+\.\d)% of the energy of (\d+) rows, "
                     r"20 re-ranked per set, [\d.]+ MB", found[0])
        self.assertIsNotNone(m, found[0])
        self.assertGreater(float(m.group(1)), 50.0, found[0])
        return int(m.group(2))

    def test_matches_are_exact_searchs_through_loads_and_unloads(self):
        r = self.load(path="day.yaml", name="", condition="")
        self.assertTrue(r.success, r.message)
        # Built after the load in the background, before any descriptor asks for it.
        self.assertEqual(self.index_rows_after(rospy.Time.now(), 200), 200)
        # One set: bsf matches the nearest place by cosine distance, which the 20 re-ranked
        # candidates make exact whenever the nearest is among them.
        day = self.day / np.linalg.norm(self.day, axis=1, keepdims=True)
        night = self.night / np.linalg.norm(self.night, axis=1, keepdims=True)
        queries = list(range(0, 200, 5))
        nearest = [int(np.argmax(day @ night[q])) for q in queries]
        got = self.matches(queries)
        same = sum(a == b for a, b in zip(got, nearest))
        self.assertGreaterEqual(same, len(queries) - 1, list(zip(queries, got, nearest)))
        # The map changes: the index follows it (the new set's codes added to it).
        r = self.load(path="day.npy", name="again", condition="")
        self.assertTrue(r.success, r.message)
        self.assertEqual(self.index_rows_after(rospy.Time.now(), 400), 400)
        self.assertEqual(len(self.matches(queries[:5])), 5)
        r = self.unload(name="day")
        self.assertTrue(r.success, r.message)
        self.assertEqual(self.index_rows_after(rospy.Time.now(), 200), 200)
        got = self.matches(queries)
        self.assertGreaterEqual(sum(a == b for a, b in zip(got, nearest)), len(queries) - 1)

if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "first_stage", FirstStage)
