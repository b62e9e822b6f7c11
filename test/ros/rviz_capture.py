"""Screenshots of rviz on a private headless X server (Xvfb), and pixel checks on them.

Used by scripts/rviz_screenshot and by rostests (which put test/ros on sys.path). Needs the
Debian packages rviz, xvfb (Xvfb), x11-apps (xwd) and x11-utils (xwininfo); numpy; nothing
else (the XWD capture is decoded and the PNG written here: no PIL, no ImageMagick).

    with RvizSession("/tmp/my.rviz", size=(1280, 800)) as rviz:   # a master must be running
        image = rviz.screenshot_when(lambda im: count_colour(im, (255, 0, 255), 30,
                                                             rviz.view_region()) > 100, 60)
        save_png(image, "/tmp/shot.png")

API: RvizSession(config, size, timeout, env, log_dir, rviz, rviz_args, check_master) with
screenshot(), screenshot_when(predicate, timeout), wait_for_view(timeout), view_region(),
render_windows(), background_rgb, display, window_after; save_png(image, path),
read_png(path), read_xwd(data); colour_mask, content_mask(image, background_rgb, tolerance),
count_colour(image, rgb, tolerance, region, shaded), find_view_region(image, background_rgb);
master_online(uri), config_background(config). Regions are (x, y, width, height) in
screenshot() coordinates (the rviz main window).

FINDINGS (tried by hand, Debian 12: rviz 1.14.19, OGRE 1.12.10, Qt 5.15.8, Xvfb 21.1.7,
Mesa llvmpipe; 2 cores busy with C++ builds, load ~2.5):
- Software GL under Xvfb renders everything needed: CUBE_LIST markers, TEXT_VIEW_FACING text,
  the Grid, the TF display, and an rviz/Image display's picture. rviz logs "OpenGL device:
  llvmpipe (LLVM 15.0.6, 256 bits)", GL 4.5 "limited to GLSL 1.4 on Mesa". Xvfb has no DRI,
  so Mesa uses llvmpipe with or without LIBGL_ALWAYS_SOFTWARE=1 (same result both ways; it is
  set anyway, for machines whose Mesa would try a GPU). No other env is needed;
  XDG_RUNTIME_DIR (set to a private folder) only silences a Qt warning, QT_X11_NO_MITSHM=1 is
  a precaution. Harmless stderr: "[rospack] Error: no such package media_export".
- Timings (RvizSession, 1280x800): rviz's window is mapped after ~0.4-0.6 s and laid out
  (render windows settled) after 0.9-1.3 s; the 3D view is drawn at 1.0-1.25 s; latched
  markers, text and the image are all on screen 1.1-1.5 s after rviz starts. An xwd capture
  + decode takes ~0.08 s, stopping rviz and Xvfb ~0.3-0.5 s. scripts/rviz_screenshot with
  --wait 2 takes ~3.4 s in all. test_rviz_capture.py: ~16 s (5 rviz starts).
- rviz renders continuously: at Frame Rate 30 it keeps ~57 % of a core busy (reports 24-31
  fps under llvmpipe), at Frame Rate 5 ~10 %. A test config can lower it.
- Colours: rviz lights 3D markers, so a (255, 0, 255) CUBE_LIST seen from above
  (TopDownOrtho) comes out as (230, 0, 230); use a tolerance >= 30 or shaded=True.
  TEXT_VIEW_FACING text is unlit: its exact colour in the glyph cores, anti-aliased edges.
  The Image display shows rgb8 colours exactly, letterboxed with black bars to keep the
  aspect ratio; before any message it shows a white "No Image" panel.
- Fonts: text markers use rviz's own OGRE font, /usr/share/rviz/ogre_media/fonts/
  liberation-sans/LiberationSans-Regular.ttf, a link into fonts-liberation (a dependency of
  rviz); the Qt widgets use fontconfig's default (DejaVu Sans, fonts-dejavu-core). Nothing
  extra to install.
- tf: markers in frame `map` with Fixed Frame `map` render even when no tf publishes `map`
  (Global Status then shows a warning); publishing any transform from map (e.g. a static
  map -> bsf_vpr_view) makes it "Ok". Debian has no tf2_ros static_transform_publisher
  binary (rosrun finds none); tf2_ros.StaticTransformBroadcaster from Python works.
- Layout (no window manager: no decorations, the window at +0+0): "Window Geometry:
  Height/Width" sets the main window's size. With 1280x800 and the Displays + Views panels
  the 3D view is the render window at x=364, y=62, 900x709 (menu bar 22 px, tool bar 40 px,
  left dock 342 px wide + splitter and a 16 px collapse button each side, status bar 29 px);
  an Image display docks at the top of the left column (its render window 342x163 at 0,84
  here) above Displays. Without a Window Geometry section rviz opens a ~700x533 window with
  the Image panel squashed to a few pixels; a geometry larger than the screen (--size) is
  clipped at the right/bottom, cutting the 3D view. So a test config should set Window
  Geometry no larger than the Xvfb screen (and may add a "QMainWindow State" to size docks).
- Xvfb -displayfd picks the first free display itself (the first it can listen on) and
  creates no /tmp/.X<n>-lock: parallel sessions got different displays. No stray
  processes: Xvfb and rviz run in sessions of their own, are stopped on every exit path
  (exception, Ctrl-C, SIGTERM in the script) and get SIGTERM from the kernel if the Python
  process is killed (PR_SET_PDEATHSIG; tried with SIGKILL).
- rviz's node name is anonymous (rviz_<time>): several rviz may share one master. rviz writes
  ~/.rviz/persistent_settings.
"""
import ctypes
import os
import re
import select
import shutil
import signal
import struct
import subprocess
import tempfile
import time
import zlib

import numpy as np

# ---------------------------------------------------------------------------------- images


def read_xwd(data):
    """Decodes an X Window Dump (the output of `xwd`, ZPixmap of a TrueColor visual with 24
    or 32 bits per pixel, as Xvfb -screen WxHx24 gives) into an HxWx3 uint8 RGB array."""
    if len(data) < 100:
        raise ValueError("XWD data too short (%d bytes)" % len(data))
    # The header is 25 CARD32 fields, big-endian (xwd writes it in network order), then the
    # window name up to header_size, then ncolors XColor records of 12 bytes, then pixels.
    fields = struct.unpack(">25I", data[:100])
    (header_size, file_version, pixmap_format, depth, width, height, _xoffset, byte_order,
     _bitmap_unit, _bitmap_bit_order, _bitmap_pad, bits_per_pixel, bytes_per_line,
     visual_class, red_mask, green_mask, blue_mask, _bits_per_rgb, _colormap_entries,
     ncolors) = fields[:20]
    if file_version != 7:
        raise ValueError("unsupported XWD version %d" % file_version)
    if pixmap_format != 2:  # ZPixmap
        raise ValueError("unsupported XWD pixmap format %d (ZPixmap only)" % pixmap_format)
    if visual_class not in (4, 5):  # TrueColor, DirectColor
        raise ValueError("unsupported XWD visual class %d (TrueColor only)" % visual_class)
    if bits_per_pixel not in (24, 32) or depth not in (24, 32):
        raise ValueError("unsupported XWD pixel size %d bits, depth %d" % (bits_per_pixel, depth))
    offset = header_size + 12 * ncolors
    need = offset + bytes_per_line * height
    if len(data) < need:
        raise ValueError("XWD data truncated: %d bytes, need %d" % (len(data), need))
    bpp = bits_per_pixel // 8
    rows = np.frombuffer(data, np.uint8, bytes_per_line * height, offset)
    rows = rows.reshape(height, bytes_per_line)[:, :width * bpp].reshape(height, width, bpp)
    if bpp == 4:
        pixels = rows.copy().view("<u4" if byte_order == 0 else ">u4")[:, :, 0]
    else:
        b = rows.astype(np.uint32)
        pixels = (b[:, :, 0] | b[:, :, 1] << 8 | b[:, :, 2] << 16) if byte_order == 0 else \
            (b[:, :, 2] | b[:, :, 1] << 8 | b[:, :, 0] << 16)
    out = np.empty((height, width, 3), np.uint8)
    for channel, mask in enumerate((red_mask, green_mask, blue_mask)):
        if mask == 0:
            raise ValueError("XWD colour mask %d is 0" % channel)
        shift = (mask & -mask).bit_length() - 1
        top = mask >> shift
        values = (pixels >> np.uint32(shift)) & np.uint32(top)
        out[:, :, channel] = values if top == 255 else (values * 255 + top // 2) // top
    return out


def _png_chunk(kind, body):
    return struct.pack(">I", len(body)) + kind + body + \
        struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def png_bytes(image):
    """An HxWx3 (RGB) or HxW (grey) uint8 array as PNG file contents."""
    image = np.asarray(image)
    if image.dtype != np.uint8 or image.ndim not in (2, 3) or \
            (image.ndim == 3 and image.shape[2] != 3):
        raise ValueError("png_bytes needs an HxWx3 or HxW uint8 array, not %s %s"
                         % (image.dtype, image.shape))
    height, width = image.shape[:2]
    colour_type = 2 if image.ndim == 3 else 0
    raw = np.zeros((height, 1 + image[0].size), np.uint8)  # filter byte 0 (None) per row
    raw[:, 1:] = image.reshape(height, -1)
    return (b"\x89PNG\r\n\x1a\n"
            + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0))
            + _png_chunk(b"IDAT", zlib.compress(raw.tobytes(), 6))
            + _png_chunk(b"IEND", b""))


def save_png(image, path):
    """Writes an HxWx3 uint8 array to `path` as PNG, atomically (a temporary file in the same
    folder, then rename): a reader never sees a partial file."""
    data = png_bytes(image)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _unfilter(raw, height, stride, bpp):
    """Undoes PNG's per-row filters (types 0-4)."""
    rows = np.frombuffer(raw, np.uint8).reshape(height, stride + 1)
    out = np.zeros((height, stride), np.uint8)
    previous = np.zeros(stride, np.int32)
    for y in range(height):
        kind = rows[y, 0]
        line = rows[y, 1:].astype(np.int32)
        if kind == 0:
            cur = line
        elif kind == 2:
            cur = (line + previous) & 0xFF
        elif kind in (1, 3, 4):  # depend on the pixel to the left: done byte by byte
            cur = np.zeros(stride, np.int32)
            for x in range(stride):
                a = cur[x - bpp] if x >= bpp else 0
                b = previous[x]
                c = previous[x - bpp] if x >= bpp else 0
                if kind == 1:
                    pred = a
                elif kind == 3:
                    pred = (a + b) // 2
                else:
                    p = a + b - c
                    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                    pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                cur[x] = (line[x] + pred) & 0xFF
        else:
            raise ValueError("bad PNG filter type %d" % kind)
        out[y] = cur
        previous = cur
    return out


def read_png(path):
    """Reads an 8-bit RGB, RGBA, grey or grey+alpha PNG (not interlaced, not palette) into an
    HxWx3 uint8 array (alpha dropped). Reads what save_png writes, fast; other PNGs with
    Sub/Average/Paeth filters are decoded too, slowly (pure Python per byte)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("%s is no PNG file" % path)
    pos, idat, header = 8, [], None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
    if header is None:
        raise ValueError("%s has no IHDR chunk" % path)
    width, height, bit_depth, colour_type, _compression, _filter, interlace = header
    channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(colour_type)
    if bit_depth != 8 or channels is None or interlace != 0:
        raise ValueError("%s: only 8-bit, non-interlaced grey/RGB(A) PNGs are read (depth %d, "
                         "colour type %d, interlace %d)"
                         % (path, bit_depth, colour_type, interlace))
    pixels = _unfilter(zlib.decompress(b"".join(idat)), height, width * channels, channels)
    pixels = pixels.reshape(height, width, channels)
    if channels <= 2:
        return np.repeat(pixels[:, :, :1], 3, axis=2)
    return np.ascontiguousarray(pixels[:, :, :3])


# ---------------------------------------------------------------------------------- pixels


def _as_rgb(rgb):
    rgb = tuple(int(c) for c in rgb)
    if len(rgb) != 3 or not all(0 <= c <= 255 for c in rgb):
        raise ValueError("a colour is 3 values 0..255, not %r" % (rgb,))
    return np.array(rgb, np.int32)


def _crop(image, region):
    if region is None:
        return image
    x, y, w, h = region
    return image[max(0, y):max(0, y + h), max(0, x):max(0, x + w)]


def colour_mask(image, rgb, tolerance=30, shaded=False):
    """HxW bool: the pixels within `tolerance` (per channel) of `rgb`. With shaded=True a pixel
    also matches a darker shade k*rgb, 0.3 <= k <= 1: rviz lights 3D markers, so a face of a
    (255, 0, 255) cube comes out as e.g. (230, 0, 230) seen from above, darker on its sides."""
    target = _as_rgb(rgb)
    pixels = np.asarray(image)[..., :3].astype(np.int32)
    if not shaded:
        return (np.abs(pixels - target) <= tolerance).all(axis=-1)
    norm = float(np.dot(target, target)) or 1.0
    k = np.clip((pixels.astype(np.float32) @ target.astype(np.float32)) / norm, 0.3, 1.0)
    return (np.abs(pixels - k[..., None] * target) <= tolerance).all(axis=-1)


def content_mask(image, background_rgb, tolerance=12):
    """HxW bool: the pixels that differ from `background_rgb` by more than `tolerance` in some
    channel: what was drawn over the background (markers, text, grid lines)."""
    return ~colour_mask(image, background_rgb, tolerance)


def count_colour(image, rgb, tolerance=30, region=None, shaded=False):
    """How many pixels of `image` (inside `region` = (x, y, width, height) when given) are
    within `tolerance` of `rgb` (see colour_mask for `shaded`)."""
    return int(colour_mask(_crop(np.asarray(image), region), rgb, tolerance, shaded).sum())


def _longest_run(flags, max_gap=0):
    """(start, length) of the longest run of True in a 1-D bool array, bridging gaps of at
    most max_gap False values inside a run; (0, 0) if there is no True."""
    best, start, last = (0, 0), None, None
    for i, flag in enumerate(flags):
        if not flag:
            continue
        if start is None or i - last - 1 > max_gap:
            start = i
        last = i
        if last - start + 1 > best[1]:
            best = (start, last - start + 1)
    return best


def find_view_region(image, background_rgb=(48, 48, 48), tolerance=6, min_fraction=0.3,
                     min_size=64, max_gap=6):
    """Finds rviz's 3D view in a screenshot from its pixels alone: the largest block of rows
    and columns in which at least `min_fraction` of the pixels have the configured background
    colour (Global Options / Background Color; rviz's default is 48; 48; 48). Grid lines and
    markers are thin or sparse enough not to break it (lines up to max_gap pixels wide are
    bridged); the Qt panels (light grey) and an Image display (the camera picture, black
    letterbox bars) are excluded. Returns (x, y, width, height), or None when no such block
    of at least min_size x min_size pixels exists (rviz has not drawn yet, or markers cover
    most of the view: then pass the region yourself, e.g. RvizSession.view_region(), which
    asks the X server instead)."""
    mask = colour_mask(image, background_rgb, tolerance)
    x0, y0, w, h = 0, 0, mask.shape[1], mask.shape[0]
    for _ in range(3):  # columns over the rows found, rows over the columns found, again
        sub = mask[y0:y0 + h]
        cs, cw = _longest_run(sub.mean(axis=0) >= min_fraction, max_gap)
        if cw < min_size:
            return None
        sub = mask[:, cs:cs + cw]
        rs, rh = _longest_run(sub.mean(axis=1) >= min_fraction, max_gap)
        if rh < min_size:
            return None
        if (cs, rs, cw, rh) == (x0, y0, w, h):
            break
        x0, y0, w, h = cs, rs, cw, rh
    return (int(x0), int(y0), int(w), int(h))


# ---------------------------------------------------------------------------------- X windows

# `   0x200010 "cfg.rviz - RViz": ("rviz" "rviz")  1280x800+0+0  +0+0`: id, name, size,
# position in the parent, absolute position; the indentation (3 per level) gives the depth.
_TREE_LINE = re.compile(
    r'^(?P<indent>\s*)(?P<id>0x[0-9a-f]+) (?P<name>"(?:[^"\\]|\\.)*"|\(has no name\))'
    r'.*?\s(?P<w>\d+)x(?P<h>\d+)\+(-?\d+)\+(-?\d+)\s+\+(?P<x>-?\d+)\+(?P<y>-?\d+)\s*$')


class Window:
    """A window from `xwininfo -root -tree`: id, name (None when it has none), absolute x, y
    on the screen, width, height, depth (nesting level, 0 = a child of the root)."""

    def __init__(self, wid, name, x, y, width, height, depth):
        self.id, self.name, self.depth = wid, name, depth
        self.x, self.y, self.width, self.height = x, y, width, height

    @property
    def region(self):
        return (self.x, self.y, self.width, self.height)

    def __repr__(self):
        return "Window(%s %r %dx%d+%d+%d depth %d)" % (self.id, self.name, self.width,
                                                       self.height, self.x, self.y, self.depth)


def parse_window_tree(text):
    """The windows listed by `xwininfo -root -tree`, in its order (each window before its
    children), with absolute positions."""
    windows, base = [], None
    for line in text.splitlines():
        m = _TREE_LINE.match(line)
        if not m:
            continue
        indent = len(m.group("indent"))
        if base is None:
            base = indent
        name = m.group("name")
        name = None if name == "(has no name)" else name[1:-1]
        windows.append(Window(m.group("id"), name, int(m.group("x")), int(m.group("y")),
                              int(m.group("w")), int(m.group("h")), (indent - base) // 3))
    return windows


def _subtree(windows, index):
    """The windows below windows[index] in a parse_window_tree list."""
    out = []
    for w in windows[index + 1:]:
        if w.depth <= windows[index].depth:
            break
        out.append(w)
    return out


# ---------------------------------------------------------------------------------- session


class RvizCaptureError(RuntimeError):
    """Xvfb or rviz did not start, or a screenshot could not be taken; the message says why
    (with the last lines rviz wrote to stderr when rviz is at fault)."""


def _die_with_parent():
    """preexec_fn: the child gets SIGTERM when the process (thread) that started it dies, so
    not even a SIGKILLed caller leaves a stray Xvfb or rviz behind."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def _tail(path, lines=15):
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-lines:]).rstrip()
    except OSError:
        return ""


def config_background(config):
    """The Background Color of an .rviz file's Global Options as (r, g, b); rviz's default
    (48, 48, 48) when the file does not set it."""
    try:
        with open(config, errors="replace") as f:
            m = re.search(r"^\s*Background Color:\s*(\d+)\s*;\s*(\d+)\s*;\s*(\d+)", f.read(), re.M)
    except OSError:
        m = None
    return tuple(int(v) for v in m.groups()) if m else (48, 48, 48)


def master_online(uri=None, timeout_s=3.0):
    """True when the ROS master at `uri` (default: ROS_MASTER_URI) answers getPid."""
    import xmlrpc.client

    class Transport(xmlrpc.client.Transport):
        def make_connection(self, host):
            connection = super().make_connection(host)
            connection.timeout = timeout_s
            return connection

    uri = uri or os.environ.get("ROS_MASTER_URI") or "http://localhost:11311"
    try:
        with xmlrpc.client.ServerProxy(uri, transport=Transport()) as master:
            return master.getPid("/rviz_capture")[0] == 1
    except (OSError, ValueError, xmlrpc.client.Error):  # refused, timeout, bad URI or reply
        return False


class RvizSession:
    """rviz with CONFIG on a private Xvfb display, software OpenGL (Mesa llvmpipe). A context
    manager: `with RvizSession(cfg) as rviz:` starts Xvfb and rviz and waits until rviz's main
    window is mapped and laid out (RvizCaptureError after `timeout` seconds, with rviz's last
    stderr lines); leaving the block stops rviz (SIGINT, then SIGTERM, then SIGKILL) and
    Xvfb, also on exceptions and Ctrl-C. Needs a ROS master (ROS_MASTER_URI, or `env`):
    checked first.

    Xvfb chooses a free display itself (-displayfd), so sessions may run side by side. Xvfb
    and rviz get SIGTERM if the thread that started them dies (PR_SET_PDEATHSIG): start a
    session from a thread that outlives it (the main thread, normally).
    `env` adds to / overrides os.environ for rviz. `log_dir` keeps Xvfb's and rviz's output
    (default: a temporary folder, removed on close). `rviz_args` are extra rviz options."""

    def __init__(self, config, size=(1280, 800), timeout=60.0, env=None, log_dir=None,
                 rviz="rviz", rviz_args=(), check_master=True):
        self.config = os.path.abspath(config)
        self.size = (int(size[0]), int(size[1]))
        self.timeout = float(timeout)
        self.env = dict(env or {})
        self.rviz = rviz
        self.rviz_args = list(rviz_args)
        self.check_master = check_master
        self.background_rgb = config_background(self.config)
        self._own_log_dir = log_dir is None
        self.log_dir = log_dir
        self.display = None
        self.xvfb = None
        self.process = None
        self.started_at = None      # time.monotonic() when rviz was started
        self.window_after = None    # seconds from rviz's start to its window laid out

    # -- lifecycle

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def start(self):
        if not os.path.isfile(self.config):
            raise RvizCaptureError("no rviz config %s" % self.config)
        rviz_env = dict(os.environ)
        rviz_env.update(self.env)
        if self.check_master and not master_online(rviz_env.get("ROS_MASTER_URI")):
            raise RvizCaptureError(
                "no ROS master answers at ROS_MASTER_URI=%s; rviz needs one: start roscore "
                "(e.g. `roscore -p 11311 &`) or set ROS_MASTER_URI"
                % rviz_env.get("ROS_MASTER_URI", "(unset: http://localhost:11311)"))
        try:
            if self.log_dir is None:
                self.log_dir = tempfile.mkdtemp(prefix="rviz_capture_")
            os.makedirs(self.log_dir, exist_ok=True)
            self._start_xvfb()
            runtime = os.path.join(self.log_dir, "xdg_runtime")
            os.makedirs(runtime, mode=0o700, exist_ok=True)
            rviz_env.update({"DISPLAY": self.display, "LIBGL_ALWAYS_SOFTWARE": "1",
                             "XDG_RUNTIME_DIR": runtime, "QT_X11_NO_MITSHM": "1"})
            rviz_env.update(self.env)
            rviz_env["DISPLAY"] = self.display
            self._rviz_out = os.path.join(self.log_dir, "rviz.stdout")
            self._rviz_err = os.path.join(self.log_dir, "rviz.stderr")
            with open(self._rviz_out, "wb") as out, open(self._rviz_err, "wb") as err:
                self.started_at = time.monotonic()
                self.process = subprocess.Popen(
                    [self.rviz, "-d", self.config] + self.rviz_args, env=rviz_env,
                    stdin=subprocess.DEVNULL, stdout=out, stderr=err, cwd=self.log_dir,
                    start_new_session=True, preexec_fn=_die_with_parent)
            self.wait_for_window(self.timeout)
        except BaseException:
            self.close()
            raise

    def _start_xvfb(self):
        read_fd, write_fd = os.pipe()
        try:
            with open(os.path.join(self.log_dir, "xvfb.log"), "wb") as log:
                self.xvfb = subprocess.Popen(
                    ["Xvfb", "-displayfd", str(write_fd), "-screen", "0",
                     "%dx%dx24" % self.size, "-nolisten", "tcp", "-noreset"],
                    pass_fds=(write_fd,), stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                    start_new_session=True, preexec_fn=_die_with_parent)
            os.close(write_fd)
            write_fd = None
            number = b""
            deadline = time.monotonic() + 30
            while not number.endswith(b"\n"):
                left = deadline - time.monotonic()
                if left <= 0 or not select.select([read_fd], [], [], left)[0]:
                    raise RvizCaptureError("Xvfb gave no display number within 30 s: %s"
                                           % _tail(os.path.join(self.log_dir, "xvfb.log")))
                chunk = os.read(read_fd, 64)
                if not chunk:
                    raise RvizCaptureError("Xvfb exited (%s): %s" % (
                        self.xvfb.poll(), _tail(os.path.join(self.log_dir, "xvfb.log"))))
                number += chunk
            self.display = ":" + number.decode().strip()
        finally:
            os.close(read_fd)
            if write_fd is not None:
                os.close(write_fd)

    def close(self):
        """Stops rviz and Xvfb (idempotent)."""
        if self.process is not None:
            _stop(self.process, (signal.SIGINT, 10), (signal.SIGTERM, 5))
            self.process = None
        if self.xvfb is not None:
            _stop(self.xvfb, (signal.SIGTERM, 5))
            self.xvfb = None
        if self._own_log_dir and self.log_dir is not None:
            shutil.rmtree(self.log_dir, ignore_errors=True)
            self.log_dir = None

    def stderr_tail(self, lines=15):
        """The last lines rviz wrote to stderr."""
        return _tail(getattr(self, "_rviz_err", ""), lines)

    # -- windows

    def _x(self, *command):
        env = dict(os.environ, DISPLAY=self.display)
        r = subprocess.run(list(command), env=env, capture_output=True, check=False)
        if r.returncode != 0:
            raise RvizCaptureError("%s failed (exit %d): %s" % (
                " ".join(command), r.returncode, r.stderr.decode(errors="replace").strip()))
        return r.stdout

    def windows(self):
        """Every window on the display (parse_window_tree of xwininfo -root -tree)."""
        return parse_window_tree(self._x("xwininfo", "-root", "-tree").decode(errors="replace"))

    def main_window(self, windows=None):
        """rviz's main window (title "CONFIG.rviz - RViz", "* " first when changed), or None
        before it is mapped."""
        windows = self.windows() if windows is None else windows
        for w in windows:
            if w.depth == 0 and w.name and re.search(r"\bRViz$", w.name) and \
                    w.width > 100 and w.height > 100:
                return w
        return None

    def render_windows(self):
        """The OpenGL render windows inside rviz's main window, largest first, with positions
        relative to screenshot(): the 3D view first, then each Image/Camera display's panel.
        (OGRE creates them as nameless child windows of their Qt widgets.)"""
        windows = self.windows()
        main = self.main_window(windows)
        if main is None:
            return []
        inside = _subtree(windows, windows.index(main))
        found = [w for w in inside if w.name is None and w.width > 1 and w.height > 1]
        found.sort(key=lambda w: -w.width * w.height)
        for w in found:
            w.x -= main.x
            w.y -= main.y
        return found

    def view_region(self):
        """(x, y, width, height) of the 3D view in screenshot() coordinates, from the X server
        (the largest render window); None before rviz made it."""
        found = self.render_windows()
        return found[0].region if found else None

    def wait_for_window(self, timeout):
        """Waits until rviz's main window is mapped and laid out (its render windows keep
        their geometry over three polls 0.2 s apart: Qt first maps them at 100x30);
        RvizCaptureError after `timeout` seconds or when rviz exits, with rviz's last stderr
        lines. Returns the main window."""
        deadline = time.monotonic() + timeout
        previous, stable = None, 0
        while True:
            if self.process.poll() is not None:
                raise RvizCaptureError("rviz exited with status %s before showing a window; "
                                       "its last stderr lines:\n%s"
                                       % (self.process.returncode, self.stderr_tail()))
            windows = self.windows()
            main = self.main_window(windows)
            layout = None
            if main is not None:
                inside = _subtree(windows, windows.index(main))
                layout = [main.region] + [w.region for w in inside if w.name is None]
            if layout is not None and len(layout) > 1 and layout == previous:
                stable += 1
                if stable >= 2:
                    self.window_after = time.monotonic() - self.started_at
                    return main
            else:
                stable = 0
            previous = layout
            if time.monotonic() > deadline:
                raise RvizCaptureError("rviz showed no window within %.1f s; its last stderr "
                                       "lines:\n%s" % (timeout, self.stderr_tail() or "(none)"))
            time.sleep(0.2)

    # -- pixels

    def screenshot(self, whole_screen=False):
        """The rviz main window (or the whole screen) now, as an HxWx3 uint8 RGB array."""
        if self.process is not None and self.process.poll() is not None:
            raise RvizCaptureError("rviz exited with status %s; its last stderr lines:\n%s"
                                   % (self.process.returncode, self.stderr_tail()))
        image = read_xwd(self._x("xwd", "-silent", "-root"))
        if whole_screen:
            return image
        main = self.main_window()
        if main is None:
            raise RvizCaptureError("rviz has no main window")
        return image[max(0, main.y):max(0, main.y + main.height),
                     max(0, main.x):max(0, main.x + main.width)].copy()

    def screenshot_when(self, predicate, timeout, interval=0.25):
        """Takes screenshots until predicate(image) is true and returns that image. After
        `timeout` seconds raises RvizCaptureError whose `image` attribute is the last one."""
        deadline = time.monotonic() + timeout
        while True:
            image = self.screenshot()
            if predicate(image):
                return image
            if time.monotonic() > deadline:
                error = RvizCaptureError("rviz did not show what was awaited within %.0f s"
                                         % timeout)
                error.image = image
                raise error
            time.sleep(interval)

    def wait_for_view(self, timeout):
        """Waits until the 3D view shows the configured background colour over most of it
        (rviz has rendered a first frame); returns that screenshot."""
        def drawn(image):
            region = self.view_region()
            if region is None or region[2] < 32 or region[3] < 32:
                return False
            view = _crop(image, region)
            return view.size and colour_mask(view, self.background_rgb, 6).mean() > 0.3
        return self.screenshot_when(drawn, timeout)

    save_png = staticmethod(save_png)


def _stop(process, *steps):
    """Signals `process` step by step ((signal, seconds to wait) each) until it exits; SIGKILL
    last. Signals its process group (it was started in a session of its own)."""
    for sig, wait_s in steps + ((signal.SIGKILL, 5),):
        if process.poll() is not None:
            return
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            pass
        try:
            process.wait(wait_s)
            return
        except subprocess.TimeoutExpired:
            continue
