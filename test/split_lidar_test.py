#!/usr/bin/env python3
"""Two lidars mapped as one: the simulated session's lidar split into two topics, each half of
every scan in a frame of its own tied by a static transform (scripts/split_lidar_bag), mapped
with `--scan-topic /scan_a --scan-topic /scan_b`, gives the one-topic map: the occupied cells of
its slice within 0.98 precision and recall of the one-topic slice's, and the count of occupied
voxels within 3 %. Also: the .pcd of each save holds a point per occupied voxel.

Usage: split_lidar_test.py RESULT_XML BIN_DIR SOURCE_DIR  (JUnit, as the other tests write)."""
import json
import os
import re
import subprocess
import sys
import tempfile

from junit_cases import write_junit


def pcd_points(path):
    with open(path, "rb") as f:
        head = f.read(2048).decode("latin-1")
    m = re.search(r"^POINTS (\d+)$", head, re.M)
    return int(m.group(1)) if m else -1


def cases(bin_dir, source_dir):
    tool = lambda name: os.path.join(bin_dir, name)
    with tempfile.TemporaryDirectory() as tmp:
        bag = os.path.join(tmp, "sim.bag")
        subprocess.run([tool("simulate_session"), "--bag", bag, "--truth", os.path.join(tmp, "truth"), "--seed", "11",
                        "--real-robot", "--no-camera"], check=True, capture_output=True)
        split = os.path.join(tmp, "split.bag")
        p = subprocess.run(["/usr/bin/python3", os.path.join(source_dir, "scripts", "split_lidar_bag"), bag, split],
                           capture_output=True, text=True)
        yield "the bag splits", p.returncode == 0, p.stderr

        def run(name, *args):
            p = subprocess.run([tool("octo_slice_map"), "--out", os.path.join(tmp, name), *args],
                               capture_output=True, text=True)
            report = json.loads(p.stdout) if p.returncode == 0 and p.stdout.strip() else {}
            return p.returncode, report, p.stderr

        code, one, err = run("one", "--bag", bag)
        yield "one topic maps", code == 0 and one.get("scans", 0) > 1000, f"exit {code}: {err[-500:]}"
        code, two, err = run("two", "--bag", split, "--scan-topic", "/scan_a", "--scan-topic", "/scan_b")
        yield "two topics map, every half scan", code == 0 and two.get("scans") == 2 * one.get("scans", -1), \
            f"exit {code}: {two.get('scans')} vs 2 x {one.get('scans')}: {err[-500:]}"
        code, half, _ = run("half", "--bag", split, "--scan-topic", "/scan_a")
        yield "one of the two topics alone is not the map", code == 0 and half.get("voxels", 0) < one.get("voxels", 0), \
            f"{half.get('voxels')} vs {one.get('voxels')}"

        a, b = pcd_points(os.path.join(tmp, "one.pcd")), pcd_points(os.path.join(tmp, "two.pcd"))
        yield "the same occupied voxels within 3 %", a > 100 and abs(b - a) <= 0.03 * a, f"{b} vs {a}"
        for kind, suffix in (("default", ""), ("incremental", "_incremental")):
            # The two-topic map judged against the one-topic map, cell for cell.
            p = subprocess.run([tool("compare_maps"), os.path.join(tmp, "two" + suffix + ".yaml"),
                                os.path.join(tmp, "one" + suffix + ".yaml"), "--tolerance", "0"],
                               capture_output=True, text=True)
            scores = json.loads(p.stdout.strip().splitlines()[-1]) if p.returncode == 0 and p.stdout.strip() else {}
            yield f"{kind} map: occupied cells' precision and recall against the one-topic map >= 0.98", \
                scores.get("precision", 0) >= 0.98 and scores.get("recall", 0) >= 0.98, p.stdout.strip()[-300:] or p.stderr


def main():
    return 1 if write_junit("split_lidar", cases(sys.argv[2], sys.argv[3]), sys.argv[1]) else 0


if __name__ == "__main__":
    sys.exit(main())
