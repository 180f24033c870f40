#!/usr/bin/env python3
"""The launch files' params_file: what it sets reaches mapper_node and wins over the args'
defaults; without it the defaults stand. Reads `roslaunch --dump-params` (nothing is started).
Also: the topic lists reach the node, and rviz/mapping.rviz is YAML that rviz can read (a config it
cannot parse opens an empty view, silently) showing the best map and the occupied voxels.

Usage: launch_params_test.py RESULT_XML  (JUnit, as the other tests write)."""
import os
import subprocess
import sys

import yaml

from junit_cases import write_junit

HERE = os.path.dirname(os.path.abspath(__file__))
LAUNCH = os.path.join(HERE, "..", "launch")
RVIZ = os.path.join(HERE, "..", "rviz", "mapping.rviz")
PARAMS = os.path.join(HERE, "data", "mapper_params.yaml")


def dump(launch, *args):
    out = subprocess.run(["roslaunch", "--dump-params", os.path.join(LAUNCH, launch), *args],
                         check=True, capture_output=True, text=True).stdout
    return yaml.safe_load(out)


def cases():
    wanted = {"/mapper_node/" + k: v for k, v in yaml.safe_load(open(PARAMS)).items()}
    for launch, extra in [("mapping.launch", []), ("replay.launch", ["bag:=/tmp/any.bag"])]:
        with_file = dump(launch, *extra, "params_file:=" + PARAMS)
        for key, value in wanted.items():
            yield f"{launch} {key} from params_file", with_file.get(key) == value, \
                f"{key} = {with_file.get(key)!r}, the file says {value!r}"
        without = dump(launch, *extra)
        yield f"{launch} defaults without params_file", without.get("/mapper_node/resolution") == 0.05, \
            f"resolution = {without.get('/mapper_node/resolution')!r}, want the arg's default 0.05"

    lists = dump("mapping.launch", "scan_topics:=/front/scan /rear/scan", "cloud_topics:=/cam/points")
    yield "mapping.launch scan_topics and cloud_topics reach the node", \
        lists.get("/mapper_node/scan_topics") == "/front/scan /rear/scan" and \
        lists.get("/mapper_node/cloud_topics") == "/cam/points", \
        f"{lists.get('/mapper_node/scan_topics')!r}, {lists.get('/mapper_node/cloud_topics')!r}"

    try:
        config = yaml.safe_load(open(RVIZ))
        displays = {d.get("Topic") or d.get("Marker Topic"): d for d in config["Visualization Manager"]["Displays"]}
        why = ""
    except (yaml.YAMLError, KeyError, TypeError) as e:
        displays, why = {}, str(e)
    yield "rviz/mapping.rviz parses", bool(displays), why
    for topic in ("/map", "/mapper_node/occupied_voxels"):
        shown = displays.get(topic, {}).get("Enabled") is True
        yield f"rviz/mapping.rviz shows {topic}", shown, f"displays: {sorted(t for t in displays if t)}"
    # A camera's height map and floor are there to switch on (off by default: /map is the map to read).
    for topic in ("/mapper_node/height_map", "/mapper_node/floor_cells"):
        yield f"rviz/mapping.rviz has {topic}", topic in displays, f"displays: {sorted(t for t in displays if t)}"


def main():
    return 1 if write_junit("launch_params", cases(), sys.argv[1]) else 0


if __name__ == "__main__":
    sys.exit(main())
