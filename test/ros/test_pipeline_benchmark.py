#!/usr/bin/python3
"""rostest: the pipeline benchmark nodelet measures every query, and int8 storage is in force."""
import os
import sys
import unittest

import rospy
import rostest

from std_msgs.msg import String

from bsf_vpr.srv import ListReferenceSets

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import wait_for  # noqa: E402


class PipelineBenchmark(unittest.TestCase):
    def test_every_query_is_timed_against_the_core(self):
        rospy.init_node("test_pipeline_benchmark")
        tables = []
        rospy.Subscriber("/bsf_vpr/pipeline_benchmark/results", String,
                         lambda m: tables.append(m.data))
        wait_for(lambda: tables, 150, "the benchmark table")
        rows = [line for line in tables[0].splitlines()
                if line.startswith("| ") and "---" not in line][1:]  # after the header
        self.assertEqual(len(rows), 2, rows)
        self.assertTrue(rows[0].startswith("| 20 Hz |"), rows[0])
        self.assertTrue(rows[1].startswith("| flat out ("), rows[1])
        for row in rows:
            cells = [c.strip() for c in row.strip("|").split("|")]
            queries, beliefs = int(cells[1]), int(cells[2])
            latency, core, overhead = float(cells[3]), float(cells[5]), float(cells[6])
            self.assertEqual(queries, 25)
            self.assertEqual(beliefs, 25, row)
            self.assertGreater(core, 0.0, row)
            # Each query's latency includes the core's time for it, so the medians keep that
            # order and the overhead is never negative.
            self.assertGreaterEqual(overhead, 0.0, row)
            self.assertGreaterEqual(latency, core, row)
        rospy.wait_for_service("/bsf_vpr/list_reference_sets", timeout=30)
        sets = rospy.ServiceProxy("/bsf_vpr/list_reference_sets", ListReferenceSets)().sets
        self.assertEqual([s.name for s in sets], ["c0", "c1", "c2"])
        self.assertEqual([s.storage for s in sets], ["int8"] * 3)
        for s in sets:  # int8: one byte per value, plus place ids and norms (8 bytes a place)
            self.assertEqual(s.memory_bytes, 300 * 256 + 300 * 8)


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_pipeline_benchmark", PipelineBenchmark)
