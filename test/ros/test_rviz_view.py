#!/usr/bin/python3
"""rostest: what a person sees in rviz. rviz shows the shipped configuration
(rviz/bsf_vpr.rviz) on a private Xvfb while the first Nordland queries run through the
pipeline (images in, with their ground truth, as a replay plays them); then, from a
screenshot, the 3D view must show the belief bars, the match pin, the true place and the
label (pixels that are neither background nor grid), and the match image panel the query
and the matched reference side by side. The screenshot and the last match image are saved
beside the fixture for a person to look at."""
import os
import sys
import threading
import unittest

import numpy as np
import rosbag
import rospy
import rosgraph
from sensor_msgs.msg import Image

from bsf_vpr.msg import Belief, QueryGroundTruth

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from rostest_util import wait_for  # noqa: E402
from rviz_capture import RvizSession, count_colour, content_mask, save_png  # noqa: E402

# Colours of belief_markers.cpp (0-1 RGB x 255) as rviz draws them (lit: shaded matches).
BAR_TOP = (255, 217, 89)      # the best place's bar
PIN_ACCEPTED = (38, 217, 64)
PIN_NOT_ACCEPTED = (255, 140, 0)
TRUE_PLACE = (0, 230, 255)
TEXT = (255, 255, 255)


def subscribers(topic):
    state = rosgraph.Master("/test_rviz_view").getSystemState()
    return next((nodes for name, nodes in state[1] if name == topic), [])


class RvizView(unittest.TestCase):
    def setUp(self):
        self.out = rospy.get_param("~out")
        os.makedirs(self.out, exist_ok=True)
        self.lock = threading.Lock()
        self.beliefs, self.match_images = {}, []
        rospy.Subscriber("/bsf_vpr/belief", Belief, self.on_belief, queue_size=100)
        rospy.Subscriber("/bsf_vpr/fusion/match_image", Image, self.on_image, queue_size=5)

    def on_belief(self, msg):
        with self.lock:
            self.beliefs[msg.header.stamp] = msg

    def on_image(self, msg):
        with self.lock:
            self.match_images.append(msg)

    def replay(self, queries):
        """Publishes the ground truth and image of the first `queries` queries of the bag,
        each after the belief of the one before."""
        images = rospy.Publisher("/camera/image_raw", Image, queue_size=10)
        truths = rospy.Publisher("/vpr/ground_truth", QueryGroundTruth, queue_size=10)
        # (Nodelets of one manager share one connection: the ingest and the fusion, which
        # reads the query images for the match image, count once.)
        wait_for(lambda: images.get_num_connections() > 0, 60, "the pipeline to subscribe")
        wait_for(lambda: truths.get_num_connections() > 0, 60, "the ground-truth subscriber")
        sent = 0
        with rosbag.Bag(rospy.get_param("~bag")) as bag:
            pending = {}
            for topic, msg, _ in bag.read_messages(["/camera/image_raw", "/vpr/ground_truth"]):
                pending.setdefault(msg.header.stamp, {})[topic] = msg
                both = pending[msg.header.stamp]
                if len(both) < 2:
                    continue
                truths.publish(both["/vpr/ground_truth"])
                images.publish(both["/camera/image_raw"])
                stamp = msg.header.stamp
                wait_for(lambda: stamp in self.beliefs, 30, "the belief of query %d" % sent)
                sent += 1
                if sent == queries:
                    return stamp
        raise AssertionError("the bag holds fewer than %d queries" % queries)

    def test_the_shipped_view_shows_the_belief_the_match_the_label_and_the_match_image(self):
        config = os.path.join(rospy.get_param("~package"), "rviz", "bsf_vpr.rviz")
        with RvizSession(config, size=(1280, 800), log_dir=self.out) as rviz:
            wait_for(lambda: len(subscribers("/bsf_vpr/belief_markers")) > 0
                     and len(subscribers("/bsf_vpr/fusion/match_image")) > 0, 60,
                     "rviz to subscribe to the markers and the match image")
            last = self.replay(rospy.get_param("~queries"))
            belief = self.beliefs[last]
            pin = PIN_ACCEPTED if belief.accepted else PIN_NOT_ACCEPTED
            windows = rviz.render_windows()
            self.assertGreaterEqual(len(windows), 2, "the 3D view and the match image panel")
            # The 3D view is right of the docked panels.
            view = max(windows, key=lambda w: w.x).region
            panel = [w for w in windows if w.region != view][0].region

            def drawn(image):
                return (count_colour(image, BAR_TOP, 40, view, shaded=True) > 20
                        and count_colour(image, pin, 40, view, shaded=True) > 20
                        and count_colour(image, TEXT, 10, view) > 150
                        and count_colour(image, TRUE_PLACE, 40, view, shaded=True) > 10)
            try:
                image = rviz.screenshot_when(drawn, 30)
            finally:
                save_png(rviz.screenshot(), os.path.join(self.out, "rviz.png"))
            x, y, w, h = view
            inside = image[y:y + h, x:x + w]
            # Neither background nor grid: markers and text over a good part of the view.
            grid = content_mask(inside, (90, 90, 90), 25) == 0
            drawn_fraction = (content_mask(inside, rviz.background_rgb, 12) & ~grid).mean()
            self.assertGreater(drawn_fraction, 0.003, "markers cover %.4f of the view"
                               % drawn_fraction)
            # The match image panel: the query (left half) and the reference (right half)
            # are pictures, not the grey placeholder of a missing image (80, 80, 80).
            px, py, pw, ph = panel
            shown = image[py:py + ph, px:px + pw]
            self.assertLess((shown > 240).all(axis=2).mean(), 0.5, "the panel says No Image")
            for half in (shown[:, :pw // 2], shown[:, pw // 2:]):
                lit = half[half.max(axis=2) > 20]  # without the letterbox bars
                placeholder = (np.abs(lit.astype(int) - 80) <= 2).all(axis=1).mean()
                self.assertLess(placeholder, 0.2, "a placeholder instead of a picture")
                self.assertGreater(lit.std(), 15, "a picture in each half of the match image")
        with self.lock:
            self.assertTrue(self.match_images, "no match image was published")
            last_image = self.match_images[-1]
        picture = np.frombuffer(last_image.data, np.uint8).reshape(
            last_image.height, last_image.width, 3)[..., ::-1]  # bgr8 -> rgb
        save_png(picture, os.path.join(self.out, "match_image.png"))


if __name__ == "__main__":
    import rostest
    rospy.init_node("test_rviz_view")
    rostest.rosrun("bsf_vpr", "rviz_view", RvizView)
