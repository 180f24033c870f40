#!/usr/bin/env python3
"""A real robot's recording through replay.launch: nothing lost, nothing misread.

simulate_session --real-robot writes the office tour as a real TurtleBot records it: a REP 117
driver (+inf = no return, -inf = too close, NaN), a lidar mount yawed 20 deg and 3 cm to the side,
odometry from drifting dead reckoning with ~1 deg of pitch and roll, the first second of scans
before any tf, and four scans recorded after the one that follows them. The bag goes through
replay.launch (roscore, rosbag play with simulated time, mapper_node with its defaults) and the
session is checked:
- every scan with a transform is inserted; only the ones before the first tf are skipped (as
  no_transform or transform_timeout), and no "time jump back" is seen in them or in the out-of-order ones;
- every +inf is read as a no-return (none counted invalid), every -inf and NaN counted;
- the saved map is octo_slice_map's from the same bag byte for byte (the node's tf, stamps and
  arrival order lose and add nothing), and it matches the simulator's ground truth (the drift of
  the odometry allowed for: within 3 cells);
- no scan missed: none dropped by ROS's queue, seen as a gap in header.seq;
- replayed again with the node stopped for 150 ms every 0.7 s (a loaded VM), no scan is lost; and
  with a queue of 5 under the same stalls, the scans ROS drops are all reported as missed.

Usage: real_robot_replay_test.py RESULT_XML BIN_DIR  (JUnit, as the other tests write)."""
import json
import os
import re
import signal
import sys
import threading
import time

from ros_session import ros_session, run, run_cases

# Bag time per wall second; scripts/test-sanitizers slows it (OSM_REPLAY_RATE): a sanitized node
# takes 3.5 ms per tilted scan, and at 20x (200 scans/s) 26 of 1684 scans were lost.
RATE = os.environ.get("OSM_REPLAY_RATE", "20")  # bag time per wall second
COMPARED = [".bt", ".ot", ".pgm"]
# Occupied cells against the truth, within 3 cells (0.15 m): the dead reckoning turns the map by
# about 2 deg over the tour, so no map matches the truth cell for cell. The incremental slice
# thickens walls it sees twice (measured: precision 0.64, recall 0.85); the global pass's map keeps
# one cell of each wall face, which covers less of the turned truth's thick walls (0.67 / 0.78). A
# mount yaw or tf chain read wrongly smears every wall and drops both far lower.
TOLERANCE = "3"
MIN_SCORES = {"ros_incremental": (0.55, 0.80), "ros": (0.60, 0.70)}  # (precision, recall)


def stall_node(port, stop_s, every_s, done):
    """Stops the mapper_node of the roscore on `port` for `stop_s` every `every_s` until `done` is
    set: the stalls of a loaded virtual machine."""
    while not done.is_set():
        for pid in (p for p in os.listdir("/proc") if p.isdigit()):
            try:
                cmdline = open(f"/proc/{pid}/cmdline", "rb").read()
                environ = open(f"/proc/{pid}/environ", "rb").read()
            except OSError:
                continue
            if b"octo_slice_mapper/mapper_node" in cmdline and re.search(rb"ROS_MASTER_URI=[^\0]*:%d/?\0" % port,
                                                                          environ):
                os.kill(int(pid), signal.SIGSTOP)
                time.sleep(stop_s)
                os.kill(int(pid), signal.SIGCONT)
        done.wait(every_s)


def replay(session, bag, name, params_file, log, stall):
    """replay.launch of `bag` at RATE, saving as `name`; with `stall`, the node stopped for 150 ms
    every 0.7 s meanwhile. session = (port, env, devel_env). Returns (exit code, session summary
    line or "")."""
    port, env, devel_env = session
    done = threading.Event()
    staller = threading.Thread(target=stall_node, args=(port, 0.15, 0.7, done)) if stall else None
    if staller:
        staller.start()
    try:
        code = run([devel_env, "roslaunch", "-p", str(port), "octo_slice_mapper", "replay.launch", "bag:=" + bag,
                    "save:=" + name, "rate:=" + RATE, "params_file:=" + params_file], log, env)
    finally:
        done.set()
        if staller:
            staller.join()
    summary = [l for l in open(log).read().splitlines() if "session summary" in l]
    return code, summary[0] if summary else ""


def counters(summary):
    return {k: int(v) for k, v in re.findall(r"(\w+)=(\d+)(?:\s|$)", summary)}


def cases(bin_dir, work):
    bag, truth = os.path.join(work, "real.bag"), os.path.join(work, "truth")
    sim_log = os.path.join(work, "simulate.txt")
    if run([os.path.join(bin_dir, "simulate_session"), "--real-robot", "--bag", bag, "--truth", truth], sim_log):
        yield "simulate", False, f"simulate_session failed (see {sim_log})"
        return
    wrote = json.loads([l for l in open(sim_log) if l.startswith("{")][0])
    offline = os.path.join(work, "offline")
    offline_log = os.path.join(work, "offline.txt")
    if run([os.path.join(bin_dir, "octo_slice_map"), "--bag", bag, "--out", offline], offline_log):
        yield "offline", False, f"octo_slice_map failed (see {offline_log})"
        return
    params, port, env, devel_env = ros_session(bin_dir, work, "")
    session = (port, env, devel_env)
    launch_log = os.path.join(work, "roslaunch.txt")
    code, summary = replay(session, bag, "ros", params, launch_log, stall=False)
    if code or not summary:
        yield "replay", False, f"roslaunch ended with {code!r} (summary written: {bool(summary)}; see {launch_log})"
        return
    c = counters(summary)
    expected = wrote["scans"] - wrote["scans_before_tf"]
    yield ("every scan with a transform inserted", c.get("scans_inserted") == expected,
           f"inserted {c.get('scans_inserted')} of {expected}: {summary.strip()}")
    # Told apart by timing only: the tf filter gives a scan up (no_transform) or it waits out
    # transform_timeout first; both say "no transform at its stamp".
    untransformed = c.get("skipped_no_transform", 0) + c.get("skipped_transform_timeout", 0)
    yield ("only the scans before the first tf skipped, for want of a transform",
           c.get("scans_skipped") == wrote["scans_before_tf"] == untransformed,
           f"{wrote['scans_before_tf']} scans came before tf: {summary.strip()}")
    yield ("no time jump seen in late or early scans", c.get("time_jumps_back") == 0, summary.strip())
    yield ("no scan missed (no gap in header.seq)", c.get("scans_missed") == 0, summary.strip())
    # The four scans recorded after the one that follows them leave gaps that they fill when they
    # come: no warning says they never reached the mapper.
    said_missed = [l for l in open(launch_log).read().splitlines() if "never reached the mapper" in l]
    yield ("no warning of missed scans for scans that came late", not said_missed, "; ".join(said_missed))
    # doc/bad-input.md: +inf is a no-return, -inf "too close" is counted as `inf` (no update), NaN as `nan`.
    yield ("+inf read as no-return, none invalid",
           c.get("no_return") == wrote["plus_inf"] and wrote["plus_inf"] > 1000,
           f"the bag's scans after tf hold {wrote['plus_inf']} +inf: {summary.strip()}")
    yield ("-inf and NaN counted", c.get("inf") == wrote["minus_inf"] and c.get("nan") == wrote["nan"],
           f"{wrote['minus_inf']} -inf, {wrote['nan']} NaN: {summary.strip()}")
    for suffix in COMPARED:
        a, b = offline + suffix, os.path.join(work, "ros" + suffix)
        same = os.path.exists(a) and os.path.exists(b) and open(a, "rb").read() == open(b, "rb").read()
        yield f"map{suffix} as octo_slice_map's", same, f"{b} differs from {a}"
    # The node stopped for 150 ms every 0.7 s (a loaded VM). Scans held back behind the ones from
    # before tf used to be looked up only in their turn, after tf (10 s of data; at 20x, 0.5 s)
    # had dropped their stamps: 8-24 skipped in 3 of 3 runs so (CI lost 17 without stalls made).
    # Every scan is inserted: ROS's scan queue (scan_queue_size, 200: 1 s at 20x) outlasts a stall;
    # at 50 it dropped 0-3 scans silently, out of the node's sight. tf2_ros's listener queue (100
    # messages, 0.1 s at 20x) dropped tf in a stall, and when that was the bag's first transforms,
    # 1-4 more scans found none (1 run in 3): the node's own listener (tf_listener.h)
    # queues 2000. The map is not compared with octo_slice_map's (while tf was dropped, poses
    # interpolated across the gaps moved a few cells; not compared since).
    def stalled_replay(name, params_file):
        log = os.path.join(work, f"roslaunch_{name}.txt")
        code, summary = replay(session, bag, name, params_file, log, stall=True)
        return code, counters(summary), f"{summary.strip()!r} (see {log})"

    code, c, said = stalled_replay("stalled", params)
    yield ("a stalling node loses no scan", not code and c.get("scans_skipped") == wrote["scans_before_tf"] and
           c.get("scans_inserted") == expected and c.get("scans_missed") == 0,
           f"{wrote['scans_before_tf']} before tf, {expected} after: {said}")
    # With a queue of 5 (0.025 s at 20x) the stalls make ROS drop scans: each is reported as
    # missed (a gap in header.seq), so that the scans of the bag are accounted for: all but those
    # dropped before the first one received, which no gap shows (a stall while the node connects:
    # up to 150 ms of scans at 20x; 6 seen).
    small_queue = os.path.join(work, "small_queue.yaml")
    with open(small_queue, "w") as f:
        f.write(open(params).read() + "scan_queue_size: 5\n")
    code, c, said = stalled_replay("small_queue", small_queue)
    accounted = c.get("scans_inserted", 0) + c.get("scans_skipped", 0) + c.get("scans_missed", 0)
    yield ("scans ROS dropped are reported as missed", not code and c.get("scans_missed", 0) > 0 and
           wrote["scans"] - 30 <= accounted <= wrote["scans"],
           f"{wrote['scans']} scans in the bag, {accounted} accounted for: {said}")
    small_queue_log = os.path.join(work, "roslaunch_small_queue.txt")
    yield ("... and logged as never having reached the mapper",
           "scan(s) never reached the mapper" in open(small_queue_log).read(), f"no such warning in {small_queue_log}")
    for name, (min_precision, min_recall) in MIN_SCORES.items():
        score_log = os.path.join(work, "compare_" + name + ".txt")
        run([os.path.join(bin_dir, "compare_maps"), os.path.join(work, name + ".yaml"), truth + ".yaml", "--tolerance",
             TOLERANCE], score_log)
        lines = [l for l in open(score_log) if l.startswith("{")]
        score = json.loads(lines[0]) if lines else {}
        yield (f"{name}.yaml matches the ground truth", score.get("precision", 0) >= min_precision and
               score.get("recall", 0) >= min_recall, f"{score} (need {min_precision} / {min_recall}; see {score_log})")


def main():
    result_xml, bin_dir = sys.argv[1], sys.argv[2]
    return run_cases("real_robot_replay", lambda work: cases(bin_dir, work), result_xml, "osm_real_robot_")


if __name__ == "__main__":
    sys.exit(main())
