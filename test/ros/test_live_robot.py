#!/usr/bin/python3
"""rostest: the pipeline on a live robot, not a bag in lockstep.

A simulated robot drives the Nordland-100 route (real frames, 256x144 JPEGs; SYNTHETIC
positions: a straight line along x with frame k of every season at x = 10 k m). Its drivers
publish as a robot's do, each at its own rate and stamped now: camera images at 10 Hz, and
its pose at 50 Hz as tf map -> base_link or as nav_msgs/Odometry. Nothing waits for a
belief before sending the next image.

1. The README's robot command (its "Running it on a robot" block, extracted and run by bash
   as written) gives a belief per camera image, and /bsf_vpr/pose near the robot.
2. A map whose sets cannot match the camera path (config/gardens_point.yaml: 4096-d
   HDC-DELF against patchnorm's 2048-d) is an ERROR in diagnostics at start-up, before any
   image.
3. Recording by pose, with tf and with Odometry: no descriptor lost to the timing of the
   poses, at least 90 of the 100 places kept, each holding the frame the offline import
   (bsf_import) gives it, and with save_images its camera image. Recording by localisation
   keeps only accepted places, each right.
   Then a lens cap: /bsf_vpr/localization says not localised, and why, within 1.6 s.
4. Localising the winter drive with the recorded set: /bsf_vpr/pose within 25 m (median) of
   the true position, with a covariance that covers the error.
5. The README's map section (import, replay and score; record on the robot; the pose-source
   variant; the replay with the new set), each block run by bash as written.
6. Without waiting for the pose (pose_wait_s 0, the former lookup) the live recording loses
   most descriptors: the wait is what keeps them.
"""
import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import Image

from bsf_vpr.msg import Belief, Localization

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rostest_util import attach_fusion_services, run_tool, wait_for  # noqa: E402
from test_launch_files import Roslaunch  # noqa: E402

SPACING_M = 10.0
CAMERA_HZ = 10.0
POSE_HZ = 50.0
SPEED_MPS = 40.0  # 4 m between images: every place has an image within 5 m of it


def readme_blocks(readme, heading):
    """The ```bash blocks of the README section under `heading` (to the next "## "), as
    written."""
    with open(readme) as f:
        text = f.read()
    start = text.index(heading)
    end = text.find("\n## ", start + len(heading))
    return re.findall(r"```bash\n(.*?)```", text[start:end if end >= 0 else None], re.S)


def readme_block(readme, heading):
    """The first ```bash block under `heading`."""
    return readme_blocks(readme, heading)[0]


class Shell:
    """A README block run by bash from the repository root after sourcing the workspace, as
    the README says, in a process group of its own (so that Ctrl-C reaches all of it)."""

    def __init__(self, repo, block, log, env=None):
        self.log = open(log, "w")
        script = "set -e\nsource build/ws/devel/setup.bash\n" + block
        self.proc = subprocess.Popen(["bash", "-c", script], cwd=repo, env=env, stdout=self.log,
                                     stderr=subprocess.STDOUT, start_new_session=True)
        self.path = log

    def output(self):
        with open(self.path, errors="replace") as f:
            return f.read()

    def wait(self, timeout_s):
        try:
            rc = self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.interrupt()
            raise AssertionError("README block did not end in %d s: %s" % (timeout_s, self.output()))
        self.log.close()
        return rc

    def interrupt(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.log.close()


class Robot:
    """The simulated robot: its pose (tf or Odometry at 50 Hz) and camera (10 Hz), each on a
    thread of its own, stamped now. x(t) runs along `schedule`: (seconds, x) breakpoints."""

    def __init__(self, frames, pose_as):
        self.frames = frames  # image k shows place k
        self.pose_as = pose_as  # "tf" or "odometry"
        self.tf = tf2_ros.TransformBroadcaster()
        self.odom = rospy.Publisher("/robot/odometry", Odometry, queue_size=50)
        self.camera = rospy.Publisher("/camera/image_raw", Image, queue_size=10)
        self.sent = []  # (stamp, x) of every image

    def x_at(self, t):
        s = self.schedule
        if t <= s[0][0]:
            return s[0][1]
        for (t0, x0), (t1, x1) in zip(s, s[1:]):
            if t <= t1:
                return x0 + (x1 - x0) * (t - t0) / (t1 - t0)
        return s[-1][1]

    def _pose_loop(self, start, end):
        period = 1.0 / POSE_HZ
        next_t = time.monotonic()
        while not self.done and not rospy.is_shutdown():
            now = rospy.Time.now()
            x = self.x_at((now - start).to_sec())
            if self.pose_as == "none":
                pass  # no localiser running
            elif self.pose_as == "tf":
                t = TransformStamped()
                t.header.stamp = now
                t.header.frame_id, t.child_frame_id = "map", "base_link"
                t.transform.translation.x = x
                t.transform.rotation.w = 1.0
                self.tf.sendTransform(t)
            else:
                o = Odometry()
                o.header.stamp = now
                o.header.frame_id, o.child_frame_id = "map", "base_link"
                o.pose.pose.position.x = x
                o.pose.pose.orientation.w = 1.0
                self.odom.publish(o)
            next_t += period
            time.sleep(max(0.0, next_t - time.monotonic()))

    def drive(self, schedule):
        """Drives `schedule`; returns [(stamp, x)] of the images sent."""
        self.schedule = schedule
        self.sent = []
        self.done = False
        start = rospy.Time.now()
        pose_thread = threading.Thread(target=self._pose_loop, args=(start, None))
        pose_thread.start()
        time.sleep(0.5)  # the robot's pose is up before its camera, as on a robot
        period = 1.0 / CAMERA_HZ
        next_t = time.monotonic()
        while True:
            now = rospy.Time.now()
            t = (now - start).to_sec()
            if t > schedule[-1][0]:
                break
            x = self.x_at(t)
            image = self.frames[min(int(round(x / SPACING_M)), len(self.frames) - 1)]
            image.header.stamp = now
            self.camera.publish(image)
            self.sent.append((now, x))
            next_t += period
            time.sleep(max(0.0, next_t - time.monotonic()))
        time.sleep(0.5)
        self.done = True
        pose_thread.join()
        return list(self.sent)


def route_schedule():
    """0 to 990 m at SPEED_MPS, with a 1 s stop at 250 m."""
    stop_at = 250.0
    t_stop = stop_at / SPEED_MPS
    return [(0.0, 0.0), (t_stop, stop_at), (t_stop + 1.0, stop_at),
            (t_stop + 1.0 + (990.0 - stop_at) / SPEED_MPS, 990.0)]


def bag_frames(path):
    """The camera images of a query bag bsf_import wrote, in order."""
    import rosbag
    with rosbag.Bag(path) as bag:
        return [m for _, m, _ in bag.read_messages(topics=["/camera/image_raw"])]


class LiveRobot(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_live_robot")
        cls.pkg = rospy.get_param("~package_dir")
        cls.repo = os.path.dirname(os.path.realpath(os.path.join(cls.pkg, "README.md")))
        cls.tmp = tempfile.mkdtemp(prefix="bsf_live_")
        images = os.path.join(cls.pkg, "data", "nordland_subset100", "256x144")
        # The answer for the recordings: fall imported offline on the shipped map's places;
        # the same import writes the robot's camera frames (bags of the JPEGs as images).
        csv = os.path.join(cls.pkg, "data", "nordland_subset100", "synthetic_route.csv")
        cls.offline = os.path.join(cls.tmp, "offline")
        run_tool("bsf_import", "--layout", "generic", "--distance", "cosine",
                 "--place-spacing-m", SPACING_M,
                 "--reference", "summer=%s/64x32/summer,%s" % (
                     os.path.join(cls.pkg, "data", "nordland_subset100"), csv),
                 "--reference", "fall=%s/fall,%s" % (images, csv),
                 "--query", "fall=%s/fall,%s" % (images, csv),
                 "--query", "winter=%s/winter,%s" % (images, csv), "--out", cls.offline)
        cls.frames = {s: bag_frames(os.path.join(cls.offline, s + ".bag"))
                      for s in ("fall", "winter")}
        with open(os.path.join(cls.offline, "fall.yaml")) as f:
            y = yaml.safe_load(f)
        cls.fall = dict(zip(y["place_ids"], np.load(os.path.join(cls.offline, y["descriptors"]))))
        cls.beliefs, cls.poses, cls.diagnostics = {}, {}, []
        rospy.Subscriber("/bsf_vpr/belief", Belief,
                         lambda m: cls.beliefs.__setitem__(m.header.stamp, m), queue_size=1000)
        rospy.Subscriber("/bsf_vpr/pose", PoseWithCovarianceStamped,
                         lambda m: cls.poses.__setitem__(m.header.stamp, m), queue_size=1000)
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls.diagnostics.append, queue_size=100)
        cls.localization, cls.localization_heard = {}, []

        def on_localization(m):
            cls.localization[m.header.stamp] = m
            cls.localization_heard.append((time.time(), m))
        rospy.Subscriber("/bsf_vpr/localization", Localization, on_localization, queue_size=1000)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def fusion_status(self, since):
        """The fusion node's diagnostics statuses published after `since` (wall time)."""
        out = []
        for array in list(self.diagnostics):
            if array.header.stamp.to_sec() < since:
                continue
            out += [s for s in array.status if s.name.endswith("fusion")]
        return out

    def assert_pose_follows(self, sent, what, min_poses):
        """/bsf_vpr/pose of the images `sent` (at least `min_poses` accepted): median error
        <= 25 m, and the covariance covering the error (3 sigma) for 90% of them."""
        errors, covered, nees = [], 0, []
        for stamp, x in sent:
            p = self.poses.get(stamp)
            if p is None:
                continue
            self.assertEqual(p.header.frame_id, "map")
            c = p.pose.covariance
            self.assertTrue(all(math.isfinite(v) for v in c), what)
            error = math.hypot(p.pose.pose.position.x - x, p.pose.pose.position.y)
            errors.append(error)
            covered += error <= 3.0 * math.sqrt(c[0] + c[7])  # 3 sigma in the plane
            e = np.array([p.pose.pose.position.x - x, p.pose.pose.position.y])
            nees.append(float(e @ np.linalg.solve(np.array([[c[0], c[1]], [c[6], c[7]]]), e)))
        self.assertGreaterEqual(len(errors), min_poses, "%s: too few poses" % what)
        median = float(np.median(errors))
        self.assertLessEqual(median, 25.0, what)
        self.assertGreaterEqual(covered, 0.9 * len(errors), "%s: covariance too small" % what)
        print("%s: %d poses of %d images, median error %.1f m, %d within 3 sigma; NEES (x, y) "
              "mean %.2f, median %.2f" % (what, len(errors), len(sent), median, covered,
                                          np.mean(nees), np.median(nees)))

    def assert_localization_follows(self, sent):
        """/bsf_vpr/localization for every image: localised when its belief was accepted, at
        its place, or held: after an accepted belief, through beliefs that accept none for up
        to localization_hold_s (1 s) that do not say off the map (P(off) <= 0.5), at the last
        accepted place with held_s; with the time since the state last changed; and the
        diagnostics' "localized". Held, the state changes less often than acceptance does
        (found driving it: it flipped with nearly every frame between two places)."""
        wait_for(lambda: all(s in self.localization for s, _ in sent[-5:]), 30,
                 "the last localization")
        since, state, localized, held, changes, flips = None, None, 0, 0, 0, 0
        accepted_before = None
        last_accepted, place = None, -1
        for stamp, _ in sent:
            loc, belief = self.localization.get(stamp), self.beliefs[stamp]
            self.assertIsNotNone(loc, "a localization per image")
            hold = (not belief.accepted and bool(state) and last_accepted is not None and
                    (stamp - last_accepted).to_sec() <= 1.0 + 1e-9 and
                    belief.off_map_probability <= 0.5)
            if belief.accepted:
                last_accepted, place = stamp, belief.match
            self.assertEqual(loc.localized, belief.accepted or hold)
            self.assertEqual(loc.place, place if loc.localized else -1)
            self.assertAlmostEqual(loc.held_s, (stamp - last_accepted).to_sec() if hold else 0.0,
                                   places=6)
            self.assertAlmostEqual(loc.off_map_probability, belief.off_map_probability)
            if state is not None and loc.localized == state:
                self.assertAlmostEqual(loc.since_s, since + (stamp - last).to_sec(), places=6)
            changes += state is not None and loc.localized != state
            flips += accepted_before is not None and belief.accepted != accepted_before
            accepted_before = belief.accepted
            since, state, last = loc.since_s, loc.localized, stamp
            localized += loc.localized
            held += hold
        self.assertGreater(localized, 0)
        keys = [v.value for s in self.fusion_status(time.time() - 3) for v in s.values
                if v.key == "localized"]
        self.assertTrue(keys, "diagnostics say whether the robot is localised")
        self.assertRegex(keys[-1], r"^(yes, at place \d+|no), for \d+\.\d s")
        print("localization: %d of %d images localised (%d held), %d changes (acceptance "
              "changed %d times); diagnostics: %s" % (localized, len(sent), held, changes, flips,
                                                      keys[-1]), flush=True)
        self.assertGreater(held, 0, "no belief was held")

    def assert_a_covered_camera_is_not_localised(self, robot, sent):
        """A lens cap after localising (found driving it live: a latched "localized: true"
        for as long as the cap stayed on): frames of 5% of the light with a sensor's noise
        (no two alike, as a real covered camera gives them) at the camera's rate, which the
        ingest drops as blind. Within localization_timeout (1 s) and the node's check (0.1 s),
        /bsf_vpr/localization says not localised and why, and the diagnostics turn WARN.
        Uncovered, the next belief localises again."""
        self.assertTrue(any(self.localization[s].localized for s, _ in sent[-20:]),
                        "the drive ended without localising: nothing to lose")
        cap = Image()
        frame = robot.frames[-1]
        cap.height, cap.width, cap.encoding, cap.step = (frame.height, frame.width,
                                                         frame.encoding, frame.step)
        light = 0.05 * sum(frame.data) / len(frame.data)
        noise = random.Random(5)
        caps = [bytes(min(255, max(0, int(round(light + noise.gauss(0, 2)))))
                      for _ in range(len(frame.data))) for _ in range(8)]
        covered = time.time()
        until = covered + 3.0
        said = None
        while time.time() < until:
            cap.data = caps[int(time.time() * CAMERA_HZ) % len(caps)]
            cap.header.stamp = rospy.Time.now()
            robot.camera.publish(cap)
            time.sleep(1.0 / CAMERA_HZ)
            heard = [(t, m) for t, m in list(self.localization_heard) if t > covered]
            if said is None and heard and not heard[-1][1].localized:
                said = heard[-1]
        self.assertIsNotNone(said, "still localised 3 s after the camera was covered")
        delay = said[0] - covered
        print("covered camera: not localised after %.2f s: %s" % (delay, said[1].reason))
        self.assertLessEqual(delay, 1.6)
        self.assertIn("shows only noise", said[1].reason)
        self.assertEqual(said[1].place, -1)
        warned = [s for s in self.fusion_status(covered) if s.level == 1 and "not localised" in
                  s.message and "shows only noise" in s.message]
        self.assertTrue(warned, "the diagnostics did not turn WARN while the camera was covered")
        # The latched message a robot that connects now reads says the same.
        latched = rospy.wait_for_message("/bsf_vpr/localization", Localization, timeout=5)
        self.assertFalse(latched.localized)

    def test_1_the_readme_robot_command_gives_a_belief_per_camera_image(self):
        block = readme_block(os.path.join(self.repo, "README.md"), "## Running it on a robot")
        home = os.path.join(self.tmp, "home")
        os.makedirs(home)
        data_before = sorted(os.listdir(os.path.join(self.repo, "data")))
        shell = Shell(self.repo, block, os.path.join(self.tmp, "readme.log"),
                      env=dict(os.environ, HOME=home))
        try:
            robot = Robot(self.frames["fall"], "tf")
            wait_for(lambda: robot.camera.get_num_connections() > 0, 60, "the README's pipeline")
            time.sleep(1.0)
            sent = robot.drive(route_schedule())
            wait_for(lambda: all(s in self.beliefs for s, _ in sent[-5:]), 30, "the last beliefs")
            got = sum(s in self.beliefs for s, _ in sent)
            self.assertEqual(got, len(sent), "a belief per camera image")
            # measured: 174 poses of 253 images, median error 2.2 m, all within 3 sigma
            self.assert_pose_follows(sent, "README robot command, fall against summer",
                                     len(sent) // 2)
            self.assert_localization_follows(sent)
            errors = [s for s in self.fusion_status(time.time() - 3) if s.level >= 2]
            self.assertEqual(errors, [])
            self.assert_a_covered_camera_is_not_localised(robot, sent)
            self.assertTrue(os.path.isdir(os.path.join(home, ".ros", "bsf_vpr")))
        finally:
            shell.interrupt()
        self.assertEqual(sorted(os.listdir(os.path.join(self.repo, "data"))), data_before)

    def test_2_sets_that_cannot_match_the_camera_are_an_error_at_start_up(self):
        launch = Roslaunch("bsf_vpr.launch", {
            "input_topic": "/camera/image_raw",
            "extra_config": os.path.join(self.pkg, "config", "gardens_point.yaml"),
            "data_directory": os.path.join(self.tmp, "gp")})
        try:
            since = time.time()
            launch.wait_until(lambda: any(s.level == 2 and "4096" in s.message and "2048" in s.message
                                          for s in self.fusion_status(since)), 60,
                              "the fusion node's start-up error")
            # A camera at 10 Hz: diagnostics show the images arriving and every one dropped.
            robot = Robot(self.frames["fall"], "tf")
            wait_for(lambda: robot.camera.get_num_connections() > 0, 60, "the ingest")
            since = time.time() + 1.5  # statuses over a window full of images
            robot.drive([(0.0, 0.0), (4.0, 160.0)])

            def values(status):
                return {v.key: v.value for v in status.values}
            rates = [values(s) for s in self.fusion_status(since)]
            self.assertTrue(rates, "no diagnostics while the camera ran")
            last = rates[-1]
            self.assertGreater(float(last["received rate (Hz)"]), 5.0, last)
            self.assertEqual(float(last["recognised rate (Hz)"]), 0.0, last)
            self.assertGreater(float(last["dropped rate (Hz)"]), 5.0, last)
        finally:
            launch.stop()
        self.assertIn("no descriptor can be recognised", launch.output())

    def record(self, places, pose_as):
        data = os.path.join(self.tmp, "rec_" + pose_as)
        config = os.path.join(self.tmp, "pose_%s.yaml" % pose_as)
        with open(config, "w") as f:
            if pose_as == "odometry":
                f.write("pose_source: topic\npose_topic: /robot/odometry\n")
            else:
                f.write("pose_source: tf\n")
        launch = Roslaunch("bsf_vpr.launch", {
            "input_topic": "/camera/image_raw", "config": config,
            "extra_config": os.path.join(self.pkg, "config", "robot_example.yaml"),
            "data_directory": data})
        return launch, data

    def check_pose_recording(self, pose_as):
        launch, data = self.record("pose", pose_as)
        try:
            launch.wait_until(lambda: self.service_up(), 60, "the fusion node")
            attach_fusion_services(self)
            r = self.start(name="fall_live", condition="fall", overwrite=False, places="pose",
                           save_images=(pose_as == "tf"))
            self.assertTrue(r.success, r.message)
            robot = Robot(self.frames["fall"], pose_as)
            wait_for(lambda: robot.camera.get_num_connections() > 0, 60, "the ingest")
            sent = robot.drive(route_schedule())
            wait_for(lambda: all(s in self.beliefs for s, _ in sent[-3:]), 30, "the last beliefs")
            r = self.stop(discard=False)
            self.assertTrue(r.success, r.message)
            self.assertEqual(r.num_received, len(sent), r.message)
            self.assertEqual(r.num_descriptors, len(sent), "lost to pose timing: " + r.message)
            self.assertGreaterEqual(r.num_places, 90, r.message)
            with open(os.path.join(data, "fall_live.yaml")) as f:
                y = yaml.safe_load(f)
            rows = np.load(os.path.join(data, y["descriptors"]))
            for place, row in zip(y["place_ids"], rows):
                np.testing.assert_allclose(row, self.fall[place], atol=1e-5,
                                           err_msg="place %d holds another frame" % place)
            print("by pose (%s): %s" % (pose_as, r.message))
            if pose_as == "tf":
                # save_images: each place keeps the camera image of its descriptor.
                # (a folder of the save's own: fall_live_images.<8 characters>)
                self.assertRegex(y["images"], r"^fall_live_images\.[a-z0-9]{8}$")
                self.assertEqual(len(y["image_files"]), r.num_places)
                self.assertTrue(all(y["image_files"]), "a place without its image: " + r.message)
                for name in y["image_files"]:
                    with open(os.path.join(data, y["images"], name), "rb") as f:
                        self.assertEqual(f.read(3), b"\xff\xd8\xff", name)  # a JPEG
            else:
                self.assertNotIn("images", y)
            if pose_as == "tf":
                # By localisation: only accepted places, each with the right frame.
                r = self.start(name="fall_localized", condition="fall", overwrite=False,
                               places="localized")
                self.assertTrue(r.success, r.message)
                sent = robot.drive(route_schedule())
                wait_for(lambda: all(s in self.beliefs for s, _ in sent[-3:]), 30, "beliefs")
                time.sleep(1.0)
                r = self.stop(discard=False)
                self.assertTrue(r.success, r.message)
                # Every frame counted, the unaccepted ones among the lost (by cause).
                self.assertEqual(r.num_received, len(sent), r.message)
                self.assertIn("not localised", r.message)
                with open(os.path.join(data, "fall_localized.yaml")) as f:
                    y = yaml.safe_load(f)
                rows = np.load(os.path.join(data, y["descriptors"]))
                self.assertGreater(len(rows), 30, r.message)
                right = sum(np.allclose(row, self.fall[p], atol=1e-5)
                            for p, row in zip(y["place_ids"], rows))
                self.assertGreaterEqual(right, 0.9 * len(rows), r.message)
                print("by localisation: %s, %d of %d places hold their own frame" % (
                    r.message, right, len(rows)))
                self.assertTrue(self.unload(name="fall_localized").success)
                # Localising with the new set: winter against summer + the live fall set.
                winter = Robot(self.frames["winter"], "tf")
                sent = winter.drive(route_schedule())
                wait_for(lambda: all(s in self.beliefs for s, _ in sent[-3:]), 30, "beliefs")
                used = self.beliefs[sent[-1][0]].set_names
                self.assertEqual(sorted(used), ["fall_live", "summer"])
                # Winter is the hard season (single images, h = 0.9): few are accepted.
                self.assert_pose_follows(sent, "winter against summer + fall recorded live", 10)
        finally:
            launch.stop()

    def service_up(self):
        try:
            rospy.wait_for_service("/bsf_vpr/start_recording", timeout=0.5)
            return True
        except rospy.ROSException:
            return False

    def test_3_recording_by_pose_from_tf_keeps_every_descriptor(self):
        self.check_pose_recording("tf")

    def test_4_recording_by_pose_from_odometry_keeps_every_descriptor(self):
        self.check_pose_recording("odometry")

    def test_6_without_waiting_for_the_pose_live_descriptors_are_lost(self):
        # What the wait is for: with pose_wait_s 0 (the former behaviour, a lookup at the
        # image's stamp without waiting) images newer than the last tf sample lose their pose.
        config = os.path.join(self.tmp, "nowait.yaml")
        with open(config, "w") as f:
            f.write("pose_source: tf\npose_wait_s: 0\n")
        launch = Roslaunch("bsf_vpr.launch", {
            "input_topic": "/camera/image_raw", "config": config,
            "extra_config": os.path.join(self.pkg, "config", "robot_example.yaml"),
            "data_directory": os.path.join(self.tmp, "nowait")})
        try:
            launch.wait_until(self.service_up, 60, "the fusion node")
            attach_fusion_services(self)
            self.assertTrue(self.start(name="nowait", condition="", overwrite=False,
                                       places="pose").success)
            robot = Robot(self.frames["fall"], "tf")
            wait_for(lambda: robot.camera.get_num_connections() > 0, 60, "the ingest")
            sent = robot.drive([(0.0, 0.0), (10.0, 400.0)])
            wait_for(lambda: all(s in self.beliefs for s, _ in sent[-3:]), 30, "the last beliefs")
            r = self.stop(discard=False)
            print("without waiting: %s" % r.message)
            self.assertEqual(r.num_received, len(sent))
            self.assertLess(r.num_descriptors, 0.5 * r.num_received, r.message)  # measured 4 of 95
            self.assertIn("no pose", r.message)
        finally:
            launch.stop()

    def test_7_a_missing_localiser_costs_recognition_nothing(self):
        # Recording by pose with nothing publishing the pose (tf and a topic): each descriptor
        # is answered at once, not after pose_wait_s, so beliefs keep pace with the camera.
        for pose_source in ("tf", "topic"):
            config = os.path.join(self.tmp, "noloc_%s.yaml" % pose_source)
            with open(config, "w") as f:
                f.write("pose_source: %s\npose_topic: /nobody/pose\npose_wait_s: 0.5\n"
                        % pose_source)
            launch = Roslaunch("bsf_vpr.launch", {
                "input_topic": "/camera/image_raw",
                "config": config,
                "extra_config": os.path.join(self.pkg, "config", "robot_example.yaml"),
                "data_directory": os.path.join(self.tmp, "noloc_" + pose_source)})
            try:
                launch.wait_until(self.service_up, 60, "the fusion node")
                attach_fusion_services(self)
                self.assertTrue(self.start(name="noloc", condition="", overwrite=False,
                                           places="pose").success)
                robot = Robot(self.frames["fall"], "none")
                wait_for(lambda: robot.camera.get_num_connections() > 0, 60, "the ingest")
                sent = robot.drive([(0.0, 0.0), (5.0, 200.0)])
                # Waiting 0.5 s for each of ~50 descriptors would put the last belief 20 s late.
                wait_for(lambda: sent[-1][0] in self.beliefs, 2.0,
                         "the last belief within 2 s of the last image (%s)" % pose_source)
                r = self.stop(discard=False)
                self.assertFalse(r.success)
                # The cause names what is missing (it said "no pose received yet").
                self.assertIn({"tf": "no pose: no transform from 'map' to 'base_link': frame '",
                               "topic": "no pose: no publisher on /nobody/pose"}[pose_source],
                              r.message)
                self.assertNotIn("no pose received yet", r.message)
                self.assertEqual(r.num_received, len(sent), r.message)
            finally:
                launch.stop()

    def test_5_the_readme_map_commands_run_as_written(self):
        # "The robot's map, end to end": import, replay and score; record on the robot (first
        # terminal: the pipeline; second: start, the drive, stop); the pose-source variant
        # starts; the replay with the new set scores better than without it.
        blocks = readme_blocks(os.path.join(self.repo, "README.md"), "## The robot's map, end to end")
        self.assertEqual(len(blocks), 5, "the README's map section changed: update this test")
        shutil.rmtree("/tmp/route", ignore_errors=True)
        logs = os.path.join(self.tmp, "map_%d.log")
        first = Shell(self.repo, blocks[0], logs % 0)
        self.assertEqual(first.wait(300), 0, first.output())
        self.assertIn("AUC", first.output())
        pipeline = Shell(self.repo, blocks[1], logs % 1)
        try:
            wait_for(self.service_up, 60, "the README's pipeline")
            second = Shell(self.repo, blocks[2], logs % 2)
            self.assertEqual(second.wait(300), 0, second.output())
            self.assertIn("success: True", second.output())
        finally:
            pipeline.interrupt()
        self.assertTrue(os.path.exists("/tmp/route/fall_tonight.yaml"))
        # The pose-source variant, with the bag's own poses (/vpr/query_pose, PoseStamped), and
        # the second terminal's commands with places: 'pose', as the README says to.
        variant = Shell(self.repo, blocks[3], logs % 3)
        try:
            wait_for(self.service_up, 60, "the pose-source variant of the pipeline")
            by_pose = blocks[2].replace("places: 'localized'", "places: 'pose'")
            by_pose = by_pose.replace("fall_tonight", "fall_by_pose")
            self.assertNotEqual(by_pose, blocks[2])
            second = Shell(self.repo, by_pose, logs % 5)
            self.assertEqual(second.wait(300), 0, second.output())
            self.assertIn("success: True", second.output())
            out = second.output()
            self.assertIn("num_received: 100", out)
            self.assertIn("num_descriptors: 100", out)  # every frame had its pose
            self.assertIn("num_places: 100", out)
        finally:
            variant.interrupt()
        last = Shell(self.repo, blocks[4], logs % 4)
        self.assertEqual(last.wait(300), 0, last.output())
        print("README map commands:", last.output().strip().splitlines()[-3:])


if __name__ == "__main__":
    rostest.rosrun("bsf_vpr", "test_live_robot", LiveRobot)
