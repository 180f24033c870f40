#!/usr/bin/env python3
"""A Radish log mapped in a real ROS session gives the offline tool's map.

The first scans of each shared dataset go through carmen2bag and replay.launch (roscore, rosbag
play with simulated time, tf, mapper_node saving with the global pass when the player asks), and
through octo_slice_map straight from the log. Both must write the same .bt, .pgm (the global pass's
map) and _incremental.pgm, byte for byte but the save id, and on the short-range logs the same .ot:
the node's adapters (LaserScan, tf, stamps, no-returns) lose and add nothing.

It also asks the session summary for every scan inserted, none skipped and no time jump back: it
once lost the last scan when the player's end stopped the session, the tf filter handed scans on
out of order now and then, and now and then lost one (hence play_bag's grace period, and the
node's arrival order and taking over of scans whose transform is there).

Usage: radish_replay_test.py RESULT_XML BIN_DIR  (JUnit, as the other tests write).
The datasets are read from $OSM_DATA_DIR (default: ../shared/data beside the checkout)."""
import gzip
import os
import sys

from ros_session import ros_session, run, run_cases

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.environ.get("OSM_DATA_DIR", os.path.join(HERE, "..", "..", "shared", "data"))
DATASETS = [("intel", "intel_corrected/intel-corrected.log.gz"),
            ("fr079", "fr079_corrected/freiburg-079-corrected.log.gz"),
            ("acapulco", "acapulco_corrected/acapulco-corrected.log.gz"),
            ("campus", "freiburg_campus_corrected/freiburg-campus-corrected.log.gz")]
SCANS = 150        # per dataset: enough to close rooms, short enough for the suite
# Bag time per wall second; the node keeps up (no scan is skipped, checked below). The long-range
# logs' scans take several times as long to insert (360 beams to 30 m), and tf keeps only 10 s of
# bag time: at 40x a node 0.25 s behind loses scans' transforms.
RATE = "40"
RATES = {"acapulco": "10", "campus": "10"}
# The files compared, without their save id line (the id hashes the whole set, .ot included).
# The .ot holds raw log-odds: on the long-range logs (returns to 50 and 80 m) a pose read through tf
# (a quaternion) differs from the log's in the last bits, and a few of thousands of log-odds come
# out one float ulp apart; the thresholded files are equal all the same.
COMPARED = {"intel": [".bt", ".ot", ".pgm", "_incremental.pgm"], "fr079": [".bt", ".ot", ".pgm", "_incremental.pgm"],
            "acapulco": [".bt", ".pgm", "_incremental.pgm"], "campus": [".bt", ".pgm", "_incremental.pgm"]}


def without_save_id(path):
    """The file's bytes without its `# save_id ...` line (map_io.h)."""
    data = open(path, "rb").read()
    start = data.find(b"# save_id ")
    return data if start < 0 else data[:start] + data[data.index(b"\n", start) + 1:]


def head_of_log(src, dst, scans):
    """The log's lines up to (not including) its (scans + 1)th laser record."""
    seen = 0
    with gzip.open(src, "rt") as inp, open(dst, "w") as out:
        for line in inp:
            if line.startswith(("FLASER", "RLASER", "ROBOTLASER1")):
                seen += 1
                if seen > scans:
                    break
            out.write(line)


def cases(bin_dir, work):
    for name, rel in DATASETS:
        path = os.path.join(DATA, rel)
        if not os.path.exists(path):
            yield name, False, f"{path} is missing (set OSM_DATA_DIR)"
            continue
        log = os.path.join(work, name + ".log")
        head_of_log(path, log, SCANS)
        bag = os.path.join(work, name + ".bag")
        if run([os.path.join(bin_dir, "carmen2bag"), log, bag], os.path.join(work, name + "_carmen2bag.txt")):
            yield name, False, "carmen2bag failed"
            continue
        offline = os.path.join(work, name + "_offline")
        if run([os.path.join(bin_dir, "octo_slice_map"), log, "--out", offline],
               os.path.join(work, name + "_offline.txt")):
            yield name, False, "octo_slice_map failed"
            continue
        params, port, env, devel_env = ros_session(bin_dir, work, name + "_")
        launch_log = os.path.join(work, name + "_roslaunch.txt")
        code = run([devel_env, "roslaunch", "-p", str(port), "octo_slice_mapper", "replay.launch", "bag:=" + bag,
                    "save:=" + name + "_ros", "optimize:=true", "warm_start:=true", "rate:=" + RATES.get(name, RATE),
                    "params_file:=" + params], launch_log, env)
        summary = [l for l in open(launch_log) if "session summary" in l]
        if code or not summary:
            yield name, False, f"roslaunch ended with {code!r} (summary written: {bool(summary)}; see {launch_log})"
            continue
        if f"scans_inserted={SCANS} scans_skipped=0 scans_missed=0 time_jumps_back=0" not in summary[0]:
            yield name, False, "the session did not insert every scan, in order: " + summary[0].strip()
            continue
        # Saved by the player, which waits for it, not on shutdown, where roslaunch kills the mapper
        # after 15 s (the whole Freiburg 079 log's global pass takes longer).
        text = open(launch_log).read()
        if "play_bag: saved:" not in text or "save on shutdown: skipped" not in text:
            yield name, False, f"the map was not saved by the player, or saved again on shutdown (see {launch_log})"
            continue
        # A replay that went well ends cleanly: no red "REQUIRED process [player] has died".
        clean = "play_bag: replay done" in text and "has died" not in text
        yield f"{name}: clean end", clean, f"the replay did not end cleanly (see {launch_log})"
        for suffix in COMPARED[name]:
            a, b = offline + suffix, os.path.join(work, name + "_ros" + suffix)
            same = os.path.exists(a) and os.path.exists(b) and without_save_id(a) == without_save_id(b)
            yield f"{name}{suffix}", same, f"{b} differs from {a}"


def failed_replay(bin_dir, work):
    """A replay whose save is refused (outside maps_dir) says so and scripts/replay exits non-zero.
    Run as from a fresh shell (no workspace sourced) with the bag's path relative: the script
    sources the build and hands roslaunch an absolute path, or the player never opens the bag."""
    bag = os.path.join(work, "intel.bag")
    if not os.path.exists(bag):
        yield "failed replay", False, "no bag from the cases before"
        return
    params, port, env, _ = ros_session(bin_dir, work, "failed_")
    build_dir = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(bin_dir))))
    fresh = {"HOME": os.environ.get("HOME", "/tmp"), "PATH": "/usr/bin:/bin", "ROS_MASTER_URI": env["ROS_MASTER_URI"],
             "OSM_BUILD_DIR": build_dir}
    log = os.path.join(work, "failed_roslaunch.txt")
    code = run([os.path.join(HERE, "..", "scripts", "replay"), os.path.relpath(bag), "-p", str(port),
                "save:=../outside", "rate:=" + RATE, "params_file:=" + params], log, fresh)
    text = open(log).read()
    yield ("failed replay: non-zero exit and a clear error", code not in (0, None) and "replay FAILED" in text and
           "outside maps_dir" in text, f"exit {code!r} (see {log})")


def main():
    result_xml, bin_dir = sys.argv[1], sys.argv[2]

    def all_cases(work):
        yield from cases(bin_dir, work)
        yield from failed_replay(bin_dir, work)
    return run_cases("radish_replay", all_cases, result_xml, "osm_radish_replay_")


if __name__ == "__main__":
    sys.exit(main())
