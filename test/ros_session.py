"""Shared by the replay tests: a free port for a roscore of their own, running a command with its
output in a log file, and running the cases in a work folder kept only when one fails."""
import os
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


def ros_session(bin_dir, work, stem):
    """What a replay through roslaunch needs: a parameters file that puts maps_dir in `work`, a
    port for a roscore of its own (whatever else runs on this machine), the environment naming
    it, and the devel space's env.sh to run through (ctest runs with the environment cached when
    cmake first ran, which on a fresh checkout lacks the devel Python path that play_bag imports
    the generated SaveMap service from). Returns (params, port, env, devel_env)."""
    params = os.path.join(work, stem + "params.yaml")
    with open(params, "w") as f:
        f.write(f"maps_dir: {work}\n")
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI=f"http://localhost:{port}")
    devel_env = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(bin_dir))), "env.sh")
    return params, port, env, devel_env
