#!/usr/bin/env python3
"""The launch files' params_file: what it sets reaches mapper_node and wins over the args'
defaults; without it the defaults stand. Reads `roslaunch --dump-params` (nothing is started).

Usage: launch_params_test.py RESULT_XML  (JUnit, as the other tests write)."""
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
LAUNCH = os.path.join(HERE, "..", "launch")
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


def main():
    suite = ET.Element("testsuite", name="launch_params")
    failures = 0
    for name, ok, message in cases():
        case = ET.SubElement(suite, "testcase", classname="launch_params", name=name)
        if not ok:
            failures += 1
            ET.SubElement(case, "failure", message=message)
            print("FAILED:", name, "-", message)
    suite.set("tests", str(len(suite)))
    suite.set("failures", str(failures))
    suite.set("errors", "0")
    ET.ElementTree(suite).write(sys.argv[1])
    print(f"{len(suite) - failures} passed, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
