"""Shared by the replay tests: a free port for a roscore of their own, running a command with its
output in a log file, and running the cases in a work folder kept only when one fails."""
import shutil
import socket
import subprocess
import tempfile

from junit_cases import write_junit


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(cmd, log, env=None):
    """The command's exit code (its output in `log`); a hang counts as a failure, not a crash."""
    with open(log, "w") as out:
        try:
            return subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, timeout=300, env=env).returncode
        except subprocess.TimeoutExpired:
            out.write(f"\n(killed after 300 s: {' '.join(cmd)})\n")
            return "a timeout"


def run_cases(suite_name, cases, result_xml, prefix):
    """Writes the JUnit file for `cases(work)` (a generator of (name, ok, message)) run in a fresh
    work folder, which is removed unless a case failed; the exit code (1 on a failure)."""
    work = tempfile.mkdtemp(prefix=prefix)
    failures = write_junit(suite_name, cases(work), result_xml)
    if failures:
        print("kept for a look:", work)
    else:
        shutil.rmtree(work)
    return 1 if failures else 0
