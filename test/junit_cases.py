"""The JUnit file the Python tests write, as gtest and rostest do (scripts/test counts them)."""
import xml.etree.ElementTree as ET


def write_junit(suite_name, cases, path):
    """Records each (name, ok, failure message) of `cases` in a JUnit file at `path`, prints the
    failures and "N passed, N failed"; returns the number of failures."""
    suite = ET.Element("testsuite", name=suite_name)
    failures = 0
    for name, ok, message in cases:
        case = ET.SubElement(suite, "testcase", classname=suite_name, name=name)
        if not ok:
            failures += 1
            ET.SubElement(case, "failure", message=message)
            print("FAILED:", name, "-", message)
    suite.set("tests", str(len(suite)))
    suite.set("failures", str(failures))
    suite.set("errors", "0")
    ET.ElementTree(suite).write(path)
    print(f"{len(suite) - failures} passed, {failures} failed")
    return failures
