#!/usr/bin/env python3
"""Records the background global pass of a running mapper_node from /diagnostics (issue 18).

    bench/record_online_pass.py OUT.csv [SECONDS]

One row per /diagnostics message: ROS time, scans inserted, kept scans, passes published, the last
pass's seconds, and how far the published optimized map was behind the newest scan when it went
out (optimized_map_age_s). Ends after SECONDS (default: when the node stops publishing for 10 s)
and prints, over all rows and over the last quarter (the map at its largest), the median and max
of that age, of the pass seconds, and of the interval between published passes (to the 1 s of
/diagnostics): a scan waits at most about one interval plus one age to appear in ~optimized_map.
"""
import csv
import statistics
import sys
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray

KEYS = ["scans_inserted", "kept_scans", "online_passes", "online_pass_s", "optimized_map_age_s"]


def main():
    out = sys.argv[1]
    limit = float(sys.argv[2]) if len(sys.argv) > 2 else None
    rospy.init_node("record_online_pass", anonymous=True)
    rows, last = [], [time.time()]

    def on_diagnostics(msg):
        for status in msg.status:
            values = {kv.key: kv.value for kv in status.values}
            if "online_passes" in values:
                rows.append([msg.header.stamp.to_sec()] + [float(values.get(k, "nan")) for k in KEYS])
                last[0] = time.time()

    rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics)
    start = time.time()
    while not rospy.is_shutdown():
        time.sleep(0.5)
        if limit is not None and time.time() - start > limit:
            break
        if limit is None and rows and time.time() - last[0] > 10.0:
            break
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["ros_time"] + KEYS)
        w.writerows(rows)
    published = [r for r in rows if r[3] > 0]
    if not published:
        print("record_online_pass: no pass published")
        return 1
    # The ROS time at which each pass was first seen published.
    seen = [(r[0], r[3]) for k, r in enumerate(published) if k == 0 or r[3] != published[k - 1][3]]
    for name, part in (("all", published), ("last quarter", published[3 * len(published) // 4:])):
        ages, passes = [r[5] for r in part], [r[4] for r in part]
        t0 = part[0][0]
        times = [t for t, _ in seen if t >= t0]
        gaps = [b - a for a, b in zip(times, times[1:])] or [float("nan")]
        print("%s: %d rows, scans %d..%d, passes %d..%d; optimized map age at publication median %.2f s max %.2f s; "
              "pass median %.2f s max %.2f s; interval between passes median %.1f s max %.1f s"
              % (name, len(part), part[0][1], part[-1][1], part[0][3], part[-1][3], statistics.median(ages), max(ages),
                 statistics.median(passes), max(passes), statistics.median(gaps), max(gaps)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
