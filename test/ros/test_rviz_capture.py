#!/usr/bin/python3
"""Self-test of rviz_capture.py and scripts/rviz_screenshot: runs its own roscore on a free
port and a marker publisher, screenshots rviz on a private Xvfb, and checks from the pixels
that a published marker is in the 3D view, that it is absent when it is not published (a
control marker of another colour shows that rviz did draw the topic), and that an Image
display shows a published image. Also unit tests of the XWD/PNG/pixel helpers.

Runs directly: /usr/bin/python3 test/ros/test_rviz_capture.py  (about 15 s on 2 cores).
Needs the Debian packages rviz, xvfb, x11-apps, x11-utils, python3-rospy; no catkin build.
"""
import os
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import textwrap
import time
import unittest

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import rviz_capture  # noqa: E402
from rviz_capture import (RvizCaptureError, RvizSession, count_colour,  # noqa: E402
                          find_view_region, read_png, read_xwd, save_png)

SCRIPT = os.path.join(HERE, "..", "..", "scripts", "rviz_screenshot")
BACKGROUND = (48, 48, 48)
PROBE = (255, 0, 255)     # the marker whose presence and absence are checked (magenta)
CONTROL = (0, 200, 0)     # always published: proves rviz drew the marker topic (green)
PICTURE = (255, 128, 0)   # the camera image's colour (orange)

CONFIG = textwrap.dedent("""\
    Panels:
      - Class: rviz/Displays
        Name: Displays
    Visualization Manager:
      Class: ""
      Displays:
        - Class: rviz/Grid
          Name: Grid
          Enabled: true
          Cell Size: 10
          Plane Cell Count: 4
          Reference Frame: <Fixed Frame>
        - Class: rviz/MarkerArray
          Name: Markers
          Enabled: true
          Marker Topic: /rviz_capture_test/markers
          Queue Size: 2
        - Class: rviz/Image
          Name: Camera
          Enabled: true
          Image Topic: /rviz_capture_test/image
          Transport Hint: raw
          Queue Size: 2
      Enabled: true
      Global Options:
        Background Color: 48; 48; 48
        Fixed Frame: map
        Frame Rate: 30
      Name: root
      Tools:
        - Class: rviz/Interact
      Value: true
      Views:
        Current:
          Class: rviz/TopDownOrtho
          Name: Current View
          Scale: 20
          X: 0
          Y: 0
        Saved: ~
    Window Geometry:
      Height: 600
      Width: 960
    """)

# Publishes latched markers in frame map (no tf needed: the fixed frame is map too) and an
# image, once a second until killed. argv[1]: "probe" adds the magenta cube.
PUBLISHER = textwrap.dedent("""\
    import sys
    import rospy
    from geometry_msgs.msg import Point
    from sensor_msgs.msg import Image
    from std_msgs.msg import ColorRGBA
    from visualization_msgs.msg import Marker, MarkerArray
    rospy.init_node("rviz_capture_test_markers", anonymous=True)
    markers = rospy.Publisher("/rviz_capture_test/markers", MarkerArray, queue_size=1, latch=True)
    images = rospy.Publisher("/rviz_capture_test/image", Image, queue_size=1, latch=True)
    array = MarkerArray()
    for i, (name, x, rgb) in enumerate([("control", -6, %r), ("probe", 6, %r)]):
        if name == "probe" and sys.argv[1:] != ["probe"]:
            continue
        m = Marker()
        m.header.frame_id = "map"
        m.ns, m.id, m.type, m.action = name, i, Marker.CUBE_LIST, Marker.ADD
        m.pose.orientation.w = 1.0
        m.scale.x = m.scale.y = m.scale.z = 3.0
        m.points = [Point(x=x, y=y, z=0.0) for y in (-4.0, 0.0, 4.0)]
        m.colors = [ColorRGBA(r=rgb[0] / 255.0, g=rgb[1] / 255.0, b=rgb[2] / 255.0, a=1.0)] * 3
        array.markers.append(m)
    image = Image(height=60, width=80, encoding="rgb8", step=240)
    image.header.frame_id = "camera"
    image.data = bytes(%r) * (60 * 80)
    while not rospy.is_shutdown():
        markers.publish(array)
        image.header.stamp = rospy.Time.now()
        images.publish(image)
        rospy.sleep(1.0)
    """) % (CONTROL, PROBE, PICTURE)


def free_port():
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def stop(process):
    """SIGINT, then SIGKILL, to the process group of a child started in its own session."""
    if process is None or process.poll() is not None:
        return
    for sig, wait_s in ((signal.SIGINT, 10), (signal.SIGKILL, 5)):
        try:
            os.killpg(process.pid, sig)
            process.wait(wait_s)
            return
        except ProcessLookupError:
            return
        except subprocess.TimeoutExpired:
            continue


def markers_in_view(session, image):
    region = session.view_region()
    return {name: count_colour(image, rgb, 25, region, shaded=True)
            for name, rgb in (("probe", PROBE), ("control", CONTROL))}


class Helpers(unittest.TestCase):
    """The XWD decoder, PNG writer/reader and pixel helpers on synthetic images."""

    def test_xwd_decodes_a_32_bit_truecolor_dump(self):
        pixels = np.array([[0x00112233, 0x00445566, 0], [0x00FF0000, 0x0000FF00, 0x000000FF]],
                          "<u4")
        header_size, ncolors = 100 + 8, 2
        header = struct.pack(">25I", header_size, 7, 2, 24, 3, 2, 0, 0, 32, 0, 32, 32, 3 * 4 + 4,
                             5, 0xFF0000, 0xFF00, 0xFF, 8, 256, ncolors, 3, 2, 0, 0, 0)
        rows = b"".join(row.tobytes() + b"\0" * 4 for row in pixels)  # 4 bytes of line pad
        data = header + b"test\0\0\0\0" + b"\0" * 12 * ncolors + rows
        image = read_xwd(data)
        self.assertEqual(image.shape, (2, 3, 3))
        self.assertEqual(image[0, 0].tolist(), [0x11, 0x22, 0x33])
        self.assertEqual(image[0, 1].tolist(), [0x44, 0x55, 0x66])
        self.assertEqual(image[1].tolist(), [[255, 0, 0], [0, 255, 0], [0, 0, 255]])
        with self.assertRaises(ValueError):
            read_xwd(data[:-5])

    def test_png_round_trip_and_atomic_write(self):
        rng = np.random.default_rng(1)
        image = rng.integers(0, 256, (37, 53, 3), dtype=np.uint8)
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "a.png")
            save_png(image, path)
            self.assertTrue(np.array_equal(read_png(path), image))
            self.assertEqual(os.listdir(folder), ["a.png"])  # no temporary file left
            with self.assertRaises(ValueError):
                save_png(image.astype(np.float32), path)
            self.assertTrue(np.array_equal(read_png(path), image))  # the old file unchanged

    def test_view_region_and_colour_counts(self):
        image = np.full((300, 400, 3), 239, np.uint8)   # Qt panel grey
        image[40:280, 120:390] = BACKGROUND              # the 3D view
        image[40:280, 200:202] = 160                     # a grid line across it
        image[100:120, 150:170] = (230, 0, 230)          # a lit magenta cube face
        self.assertEqual(find_view_region(image, BACKGROUND), (120, 40, 270, 240))
        self.assertEqual(count_colour(image, PROBE, 30, (120, 40, 270, 240)), 400)
        self.assertEqual(count_colour(image, PROBE, 30, (0, 0, 100, 100)), 0)
        self.assertEqual(count_colour(image, (115, 0, 115), 10), 0)
        self.assertEqual(count_colour(image, (115, 0, 115), 10, shaded=True), 0)  # brighter: no
        self.assertEqual(count_colour(image, PROBE, 10, shaded=True), 400)
        self.assertIsNone(find_view_region(np.full((300, 400, 3), 239, np.uint8), BACKGROUND))

    def test_window_tree_parsing(self):
        tree = textwrap.dedent("""\
            xwininfo: Window id: 0x50d (the root window) (has no name)

              Root window id: 0x50d (the root window) (has no name)
              Parent window id: 0x0 (none)
                 2 children:
                 0x200010 "cfg.rviz - RViz": ("rviz" "rviz")  1280x800+0+0  +0+0
                    2 children:
                    0x200014 "rviz": ("rviz" "rviz")  932x709+348+62  +348+62
                       1 child:
                       0x600004 (has no name): ()  900x709+16+0  +364+62
                    0x20010b "rviz": ("rviz" "rviz")  342x185+0+62  +0+62
                 0x200004 "Qt Selection Owner for rviz": ()  3x3+0+0  +0+0
            """)
        windows = rviz_capture.parse_window_tree(tree)
        self.assertEqual([w.id for w in windows],
                         ["0x200010", "0x200014", "0x600004", "0x20010b", "0x200004"])
        self.assertEqual([w.depth for w in windows], [0, 1, 2, 1, 0])
        self.assertEqual(windows[2].region, (364, 62, 900, 709))
        self.assertIsNone(windows[2].name)
        self.assertEqual(windows[0].name, "cfg.rviz - RViz")


class WithMaster(unittest.TestCase):
    """rviz on Xvfb against a roscore of this test's own."""

    @classmethod
    def setUpClass(cls):
        cls.folder = tempfile.mkdtemp(prefix="test_rviz_capture_")
        cls.port = free_port()
        cls.env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % cls.port,
                       ROS_LOG_DIR=os.path.join(cls.folder, "ros_log"),
                       PATH="/usr/bin:" + os.environ.get("PATH", ""))
        cls.env.pop("ROS_IP", None)
        cls.env.pop("ROS_HOSTNAME", None)
        cls.config = os.path.join(cls.folder, "test.rviz")
        with open(cls.config, "w") as f:
            f.write(CONFIG)
        cls.publisher_py = os.path.join(cls.folder, "publisher.py")
        with open(cls.publisher_py, "w") as f:
            f.write(PUBLISHER)
        with open(os.path.join(cls.folder, "roscore.log"), "wb") as log:
            cls.roscore = subprocess.Popen(
                ["roscore", "-p", str(cls.port)], env=cls.env, stdin=subprocess.DEVNULL,
                stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + 60
        while not rviz_capture.master_online(cls.env["ROS_MASTER_URI"]):
            if cls.roscore.poll() is not None or time.monotonic() > deadline:
                stop(cls.roscore)
                raise RuntimeError("roscore -p %d did not come up" % cls.port)
            time.sleep(0.1)
        cls.publisher = None

    @classmethod
    def tearDownClass(cls):
        stop(cls.publisher)
        stop(cls.roscore)
        import shutil
        shutil.rmtree(cls.folder, ignore_errors=True)

    def publish(self, *args):
        """(Re)starts the marker publisher with `args` (latched topics: rviz gets them when it
        subscribes)."""
        stop(WithMaster.publisher)
        with open(os.path.join(self.folder, "publisher.log"), "ab") as log:
            WithMaster.publisher = subprocess.Popen(
                ["/usr/bin/python3", self.publisher_py] + list(args), env=self.env,
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log,
                start_new_session=True)

    def session(self):
        return RvizSession(self.config, size=(960, 600), timeout=60, env=self.env)

    def save_failure(self, name, image):
        path = os.path.join(tempfile.gettempdir(), "test_rviz_capture_%s.png" % name)
        save_png(image, path)
        return path

    def test_marker_is_seen_when_published(self):
        self.publish("probe")
        with self.session() as rviz:
            self.assertEqual(rviz.background_rgb, BACKGROUND)
            rviz.wait_for_view(60)
            region = rviz.view_region()
            self.assertIsNotNone(region)
            try:
                image = rviz.screenshot_when(
                    lambda im: min(markers_in_view(rviz, im).values()) > 500, 60)
            except RvizCaptureError as e:
                self.fail("%s: %s; screenshot %s" % (e, markers_in_view(rviz, e.image),
                                                     self.save_failure("seen", e.image)))
            self.assertEqual(find_view_region(image, BACKGROUND), region)
            # Three cubes of 3 m at 20 px/m: ~3 x 60 x 60 pixels each colour.
            counts = markers_in_view(rviz, image)
            self.assertGreater(counts["probe"], 3 * 50 * 50, counts)
            self.assertLess(counts["probe"], 3 * 70 * 70, counts)
            # The Image display's own render window shows the picture.
            panels = rviz.render_windows()
            self.assertGreaterEqual(len(panels), 2, panels)
            image = rviz.screenshot_when(
                lambda im: count_colour(im, PICTURE, 10, panels[1].region) > 1000, 30)
            self.assertEqual(count_colour(image, PICTURE, 10, region), 0)

    def test_marker_is_absent_when_not_published(self):
        self.publish()  # the control marker only
        with self.session() as rviz:
            rviz.wait_for_view(60)
            try:
                image = rviz.screenshot_when(
                    lambda im: markers_in_view(rviz, im)["control"] > 3 * 50 * 50, 60)
            except RvizCaptureError as e:
                self.fail("%s: %s; screenshot %s" % (e, markers_in_view(rviz, e.image),
                                                     self.save_failure("absent", e.image)))
            self.assertEqual(markers_in_view(rviz, image)["probe"], 0)
            self.assertEqual(count_colour(image, PROBE, 60), 0)  # nowhere in the window

    def test_session_stops_xvfb_and_rviz(self):
        self.publish()
        with self.session() as rviz:
            processes = [rviz.process, rviz.xvfb]
            socket_path = "/tmp/.X11-unix/X" + rviz.display.lstrip(":")
            self.assertTrue(os.path.exists(socket_path))
        for p in processes:
            self.assertIsNotNone(p.poll(), "process %d still runs" % p.pid)
        self.assertFalse(os.path.exists(socket_path))

    def test_no_master_is_a_clear_error(self):
        env = dict(self.env, ROS_MASTER_URI="http://localhost:%d" % free_port())
        with self.assertRaisesRegex(RvizCaptureError, "no ROS master answers"):
            RvizSession(self.config, env=env).start()
        r = subprocess.run([SCRIPT, "--config", self.config, "--out",
                            os.path.join(self.folder, "never.png")], env=env,
                           capture_output=True, text=True, check=False)
        self.assertEqual(r.returncode, 1, r.stderr)
        self.assertIn("no ROS master answers", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.folder, "never.png")))

    def test_script_writes_a_png_with_the_marker(self):
        self.publish("probe")
        out = os.path.join(self.folder, "shot.png")
        r = subprocess.run([SCRIPT, "--config", self.config, "--out", out, "--wait", "2",
                            "--size", "960x600"], env=self.env, capture_output=True, text=True,
                           check=False, timeout=120)
        self.assertEqual(r.returncode, 0, r.stderr)
        image = read_png(out)
        self.assertEqual(image.shape, (600, 960, 3))
        region = find_view_region(image, BACKGROUND)
        self.assertIsNotNone(region)
        self.assertGreater(count_colour(image, PROBE, 25, region, shaded=True), 3 * 50 * 50)


if __name__ == "__main__":
    if any(a.startswith("--gtest_output") for a in sys.argv):  # under rostest
        import rostest
        rostest.rosrun("bsf_vpr", "rviz_capture", "__main__")  # every class of this file
    else:
        unittest.main(verbosity=2)
