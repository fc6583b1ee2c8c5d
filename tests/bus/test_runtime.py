"""Process plumbing (bus/runtime.py): a process asked to stop always ends, even when its
clean-up hangs. Real processes, readiness from their stdout, no sleeps."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest

from shoal.tools.procs.swarm import SUPERVISOR_ENV

_HANGS_IN_CLEANUP = """
import threading
from shoal.bus.runtime import announce_ready, exit_on_signals
exit_on_signals(grace={grace})
try:
    announce_ready("child")
    threading.Event().wait()
finally:
    if {hang}:
        while True:  # a clean-up that never ends, and swallows the next signal's SystemExit
            try:
                threading.Event().wait()
            except SystemExit:
                pass
"""


def _started(grace: int, hang: bool) -> subprocess.Popen[str]:
    code = _HANGS_IN_CLEANUP.format(grace=grace, hang=hang)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready child"
    return proc


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_stop_signal_becomes_a_clean_exit_with_128_plus_the_signal(sig: int) -> None:
    with _started(grace=10, hang=False) as proc:
        proc.send_signal(sig)
        assert proc.wait(timeout=30) == 128 + sig


def test_a_clean_up_that_hangs_is_ended_by_the_watchdog_even_through_a_second_signal() -> None:
    with _started(grace=1, hang=True) as proc:
        try:
            proc.send_signal(signal.SIGTERM)
            proc.send_signal(signal.SIGTERM)  # must not cancel the watchdog
            assert proc.wait(timeout=30) == -signal.SIGALRM
        finally:
            proc.kill()


def test_a_child_whose_supervisor_is_not_its_parent_leaves_at_once() -> None:
    """tools/procs/swarm.py, adopt_supervisor: a child started for a supervisor that has died (so
    the child was re-parented) exits 1 before doing anything; under its real supervisor it runs."""
    command = [sys.executable, "-m", "shoal.tools", "scenarios"]
    env = {**os.environ, SUPERVISOR_ENV: "1"}  # init is nobody's supervisor here
    orphan = subprocess.run(command, env=env, capture_output=True, text=True, timeout=60)
    assert (orphan.returncode, orphan.stdout) == (1, "")
    env[SUPERVISOR_ENV] = str(os.getpid())
    supervised = subprocess.run(command, env=env, capture_output=True, text=True, timeout=60)
    assert supervised.returncode == 0 and "default" in supervised.stdout
