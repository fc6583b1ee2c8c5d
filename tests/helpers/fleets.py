"""``shoal robots`` as its own router on a free port, for the tests of simulated ROS 2 robots
(tests/tools/test_fleet.py, test_fleet_physics.py): started, ready when it says so on stdout
(its own readiness line, not a sleep), stopped with SIGINT as a user would."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
from collections.abc import Iterator

from shoal.tools.procs.launch import free_port


@contextlib.contextmanager
def robots_process(args: list[str], ready: str) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """``shoal robots ARGS --listen <a free port>``, once its readiness line starts with
    ``ready``: (its endpoint, the process)."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "shoal.tools", "robots", *args, "--listen", endpoint],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert line.startswith(ready), line + (
            proc.stderr.read() if proc.poll() is not None and proc.stderr else ""
        )
        yield endpoint, proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(20.0)
            except subprocess.TimeoutExpired:
                proc.kill()
