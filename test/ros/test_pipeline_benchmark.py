#!/usr/bin/python3
"""rostest: the pipeline benchmark nodelet measures every query against the core's own time,
with descriptor queries (int8 storage in force) or with images described by ingest
(~images: true; the describe time is part of the core's time)."""
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
        images = rospy.get_param("~images", False)
        tables = []
        rospy.Subscriber("/bsf_vpr/pipeline_benchmark/results", String,
                         lambda m: tables.append(m.data))
        wait_for(lambda: tables, 150, "the benchmark table")
        lines = [line for line in tables[0].splitlines()
                 if line.startswith("| ") and "---" not in line]
        header = [c.strip() for c in lines[0].strip("|").split("|")]
        rows = [dict(zip(header, (c.strip() for c in line.strip("|").split("|"))))
                for line in lines[1:]]
        self.assertEqual(len(rows), 2, rows)
        self.assertTrue(rows[0]["rate"].startswith("20 Hz"), rows[0])
        self.assertTrue(rows[1]["rate"].startswith("flat out ("), rows[1])
        self.assertEqual("describe median ms" in header, images, header)
        self.assertNotIn("without a describe time", tables[0])
        for row in rows:
            self.assertEqual(int(row["queries"]), 25)
            self.assertEqual(int(row["beliefs"]), 25, row)
            latency, core = float(row["latency median ms"]), float(row["core median ms"])
            overhead = float(row["overhead median ms"])
            self.assertGreater(core, 0.0, row)
            # Each query's latency includes the core's time for it, so the medians keep that
            # order and the overhead is never negative.
            self.assertGreaterEqual(overhead, 0.0, row)
            self.assertGreaterEqual(latency, core, row)
            if images:
                self.assertGreater(float(row["describe median ms"]), 0.0, row)
                self.assertGreater(float(row["fusion median ms"]), 0.0, row)
        rospy.wait_for_service("/bsf_vpr/list_reference_sets", timeout=30)
        sets = rospy.ServiceProxy("/bsf_vpr/list_reference_sets", ListReferenceSets)().sets
        self.assertEqual([s.name for s in sets], rospy.get_param("~sets"))
        storage = rospy.get_param("~storage")
        self.assertEqual([s.storage for s in sets], [storage] * len(sets))
        if rospy.has_param("~descriptor_type"):  # the describer the launch file was given
            self.assertEqual([s.descriptor_type for s in sets],
                             [rospy.get_param("~descriptor_type")] * len(sets))
        if storage == "int8":  # one byte per value, plus place ids and norms (8 bytes a place)
            for s in sets:
                self.assertEqual(s.memory_bytes, s.num_places * s.dimension + s.num_places * 8)


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_pipeline_benchmark", PipelineBenchmark)
