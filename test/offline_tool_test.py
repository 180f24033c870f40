#!/usr/bin/env python3
"""octo_slice_map on hostile CARMEN logs: a pose the octree cannot hold
(finite, 1e30) and a NaN pose are skipped, counted and reported with their line numbers, and the
map is the one the other lines make. And on a depth camera's bag: the slice's default band.

Usage: offline_tool_test.py RESULT_XML BIN_DIR  (JUnit, as the other tests write)."""
import json
import os
import subprocess
import sys
import tempfile

from junit_cases import write_junit


def flaser_line(i, pose=None):
    """Line i of a log: 180 returns of 2 m, the robot 5 cm further along x each line."""
    ranges = " ".join(["2.0"] * 180)
    pose = pose or f"{0.05 * i:.6g}"
    t = 10.0 + 0.1 * i
    return f"FLASER 180 {ranges} {pose} 0.0 0.0 {pose} 0.0 0.0 {t:.3f} host {t:.3f}"


def write_log(path, bad_index=None, bad_pose=None):
    with open(path, "w") as f:
        for i in range(41):
            f.write(flaser_line(i, bad_pose if i == bad_index else None) + "\n")


def run(tool, log, out):
    p = subprocess.run([tool, log, "--out", out], capture_output=True, text=True)
    report = json.loads(p.stdout) if p.returncode == 0 and p.stdout.strip() else {}
    return p.returncode, report, p.stderr


def cases(bin_dir):
    tool = os.path.join(bin_dir, "octo_slice_map")
    with tempfile.TemporaryDirectory() as tmp:
        clean = os.path.join(tmp, "clean.log")
        with open(clean, "w") as f:  # the 40 lines the hostile logs have besides their bad one
            for i in range(41):
                if i != 20:
                    f.write(flaser_line(i) + "\n")
        code, clean_report, _ = run(tool, clean, os.path.join(tmp, "clean"))
        yield "the clean log maps", code == 0 and clean_report.get("scans") == 40, f"exit {code}, {clean_report}"
        clean_bt = open(os.path.join(tmp, "clean.bt"), "rb").read() if code == 0 else b""

        huge = os.path.join(tmp, "huge_pose.log")
        write_log(huge, bad_index=20, bad_pose="1e30")
        code, report, err = run(tool, huge, os.path.join(tmp, "huge"))
        yield "a 1e30 pose: the tool succeeds", code == 0, f"exit {code}: {err}"
        yield "a 1e30 pose: counted as a skipped scan", \
            report.get("scans") == 40 and report.get("skipped_scans", {}).get("invalid_scan") == 1, str(report)
        yield "a 1e30 pose: reported with its line number and why", \
            "huge_pose.log:21:" in err and "outside what the octree holds" in err, err.strip()
        same = code == 0 and open(os.path.join(tmp, "huge.bt"), "rb").read() == clean_bt
        yield "a 1e30 pose: the map is the other lines' map", same, "the .bt differs from the clean log's"

        nan = os.path.join(tmp, "nan_pose.log")
        write_log(nan, bad_index=20, bad_pose="nan")
        code, report, err = run(tool, nan, os.path.join(tmp, "nan"))
        yield "a NaN pose: counted as a bad line and reported with its number", \
            code == 0 and report.get("bad_lines") == 1 and "nan_pose.log:21:" in err, f"exit {code}, {report}, {err}"

        # A depth camera's bag: without a band given, the slice is the navigation band (0.05-0.80 m,
        # as mapping.launch camera:=true), which the lidar's band (0.16-0.36 m) is not.
        bag = os.path.join(tmp, "office.bag")
        made = subprocess.run([os.path.join(bin_dir, "simulate_session"), "--bag", bag, "--truth",
                               os.path.join(tmp, "truth")], capture_output=True, text=True).returncode == 0
        slices = {}
        for name, band in (("default", []), ("nav", ["0.05", "0.80"]), ("lidar", ["0.16", "0.36"])):
            args = [tool, "--bag", bag, "--scan-topic", "", "--cloud-topic", "/camera/depth/points", "--no-optimize",
                    "--out", os.path.join(tmp, "camera_" + name)]
            if band:
                args += ["--slice-min-z", band[0], "--slice-max-z", band[1]]
            ok = made and subprocess.run(args, capture_output=True, text=True).returncode == 0
            slices[name] = open(os.path.join(tmp, f"camera_{name}.pgm"), "rb").read() if ok else None
        yield "a camera's bag: the default slice is the navigation band", \
            slices["default"] is not None and slices["default"] == slices["nav"] and slices["default"] != slices["lidar"], \
            f"simulated: {made}; slices written: {[k for k, v in slices.items() if v is not None]}"


def main():
    return 1 if write_junit("offline_tool", cases(sys.argv[2]), sys.argv[1]) else 0


if __name__ == "__main__":
    sys.exit(main())
