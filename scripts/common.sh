# Shared by scripts/setup, scripts/demo and scripts/test: paths and a clean environment.
# Sourced, not run.

# A pyenv (or other) python3 earlier on PATH breaks catkin: Debian's ROS lives in /usr.
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:${PATH}"
# Resolve links: the scripts may be reached through the workspace's link to this folder.
BSF_REPO="$(cd "$(dirname "$(readlink -f "${BASH_SOURCE[0]}")")/.." && pwd)"
BSF_WS="${BSF_REPO}/build/ws"
export BSF_REPO BSF_WS

# Makes rosrun/roslaunch find the package built under build/ws.
bsf_source_workspace() {
  # setup.bash reads unset variables; relax nounset while it runs.
  set +u
  # shellcheck disable=SC1091
  source "${BSF_WS}/devel/setup.bash"
  set -u
}

# bsf_write_junit <suite> <file> <case name> <seconds> <log file or ""> [failure message]
# One JUnit test case "<suite>.<case name>" in <file>, where scripts/test counts it; it fails
# when a message is given, with the log from its first error report (or the log's last 200
# lines) as the failure text. Used by scripts/sanitize and scripts/cross_arm64.
bsf_write_junit() {
  /usr/bin/python3 - "$@" <<'PY'
import sys
import xml.etree.ElementTree as ET

suite_name, path, name, seconds, log = sys.argv[1:6]
message = sys.argv[6] if len(sys.argv) > 6 else ""
suite = ET.Element("testsuite", name=suite_name, tests="1", failures="1" if message else "0",
                   time=seconds)
case = ET.SubElement(suite, "testcase", classname=suite_name, name=name, time=seconds)
text = ""
if log:
    with open(log, errors="replace") as f:
        lines = f.readlines()
    # From the first report of a sanitizer, libFuzzer, gtest or the target, else the end of the log.
    marks = ("ERROR:", "runtime error:", "FINDING:", "deadly signal", "out-of-memory",
             "error:", "[  FAILED  ]")
    first = next((i for i, l in enumerate(lines) if any(m in l for m in marks)), None)
    text = "".join(lines[max(first - 2, 0):][:300] if first is not None else lines[-200:])
if message:
    ET.SubElement(case, "failure", message=message).text = text
elif text:
    ET.SubElement(case, "system-out").text = text
ET.ElementTree(suite).write(path, encoding="utf-8", xml_declaration=True)
PY
}
