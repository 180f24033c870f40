#!/usr/bin/env python3
"""Measures how long a scan takes to show in the optimized map of a running mapper_node.

    bench/record_online_pass.py OUT.csv [SECONDS]

Listens to /scan and /mapper_node/optimized_map. Each optimized map is stamped with the newest
scan it explains, so a scan first shows in the first optimized map whose stamp is at or after the
scan's; its scan-to-display time is that map's arrival (ROS time, the bag's clock) minus the
scan's stamp. Writes one row per scan (stamp, shown at, seconds) and prints the median, p99 and
max over the session and over its last quarter (the map at its largest), with the passes' count
and the interval between them. Ends after SECONDS (default: 10 s of wall time without a message
once something arrived). Scans newer than the last published map are not counted.
"""
import bisect
import csv
import statistics
import sys
import time

import rospy
from nav_msgs.msg import OccupancyGrid
from sensor_msgs.msg import LaserScan


def quantile(values, q):
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))]


def main():
    out = sys.argv[1]
    limit = float(sys.argv[2]) if len(sys.argv) > 2 else None
    rospy.init_node("record_online_pass", anonymous=True)
    scans, maps, last = [], [], [None]

    def on_scan(msg):
        scans.append(msg.header.stamp.to_sec())
        last[0] = time.time()

    def on_map(msg):
        maps.append((msg.header.stamp.to_sec(), rospy.Time.now().to_sec()))
        last[0] = time.time()

    rospy.Subscriber("/scan", LaserScan, on_scan, queue_size=1000)
    rospy.Subscriber("/mapper_node/optimized_map", OccupancyGrid, on_map, queue_size=10)
    start = time.time()
    while not rospy.is_shutdown():
        time.sleep(0.5)
        if limit is not None and time.time() - start > limit:
            break
        if limit is None and last[0] is not None and time.time() - last[0] > 10.0:
            break
    if not maps:
        print("record_online_pass: no optimized map published")
        return 1
    maps.sort()
    stamps = [m[0] for m in maps]
    rows = []
    for t in sorted(scans):
        k = bisect.bisect_left(stamps, t - 1e-6)
        if k == len(maps):
            break  # newer than the last published map
        shown = min(arrival for stamp, arrival in maps[k:] if stamp >= t - 1e-6)
        rows.append((t, shown, shown - t))
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scan_stamp", "shown_at", "scan_to_display_s"])
        w.writerows(rows)
    if not rows:
        print("record_online_pass: no scan shown")
        return 1
    arrivals = sorted(a for _, a in maps)
    for name, part in (("all", rows), ("last quarter", rows[3 * len(rows) // 4:])):
        delays = [r[2] for r in part]
        seen = [a for a in arrivals if a >= part[0][0]]
        gaps = [b - a for a, b in zip(seen, seen[1:])] or [float("nan")]
        print("%s: %d scans, %d passes published; scan to optimized map median %.2f s, p99 %.2f s, max %.2f s; "
              "interval between passes median %.2f s, max %.2f s"
              % (name, len(part), len(seen), statistics.median(delays), quantile(delays, 0.99), max(delays),
                 statistics.median(gaps), max(gaps)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
