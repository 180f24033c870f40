"""Shared by the replay tests: a free port for a roscore of their own, and running a command with
its output in a log file."""
import socket
import subprocess


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
