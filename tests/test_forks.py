"""The agents' fork server (tools/zygote.py, tools/forks.py) with real processes: what a forked
process reports, and that no way of ending the server leaves one of them behind."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from conftest import descendants, still_running

from tools.launch import free_port
from tools.swarm import ChildFailed, Swarm


def _router_args() -> list[str]:
    """A command that runs until SIGTERM: a Zenoh router on a free loopback port."""
    return ["router", "--listen", f"tcp/127.0.0.1:{free_port()}"]


def _name(pid: int) -> str:
    return Path(f"/proc/{pid}/comm").read_text().strip()


def _gone(snapshot: dict[int, tuple[str, str]], within: float = 15.0) -> dict[int, str]:
    """Those of ``snapshot`` still running once they all ended or ``within`` s passed."""
    deadline = time.monotonic() + within
    while still_running(snapshot) and time.monotonic() < deadline:
        os.sched_yield()  # waiting on a condition with a deadline, not on the clock
    return still_running(snapshot)


def test_a_forked_command_reports_its_exit_code_and_writes_stderr_to_its_log() -> None:
    with Swarm() as swarm:
        ok = swarm.spawn("agent 1", "agent", ["scenarios"])
        bad = swarm.spawn("agent 2", "agent", ["no-such-command"])
        assert ok.popen.wait(timeout=30) == 0
        assert bad.popen.wait(timeout=30) == 2  # click's usage error
        assert "No such command 'no-such-command'" in bad.tail()
        assert swarm.zygote is not None and swarm.zygote.popen.poll() is None


def test_a_forked_process_is_named_and_its_signal_death_is_reported() -> None:
    with Swarm() as swarm:
        child = swarm.spawn("agent 7", "agent", _router_args())
        assert child.popen.poll() is None
        assert _name(child.popen.pid) == "agent 7"
        os.kill(child.popen.pid, signal.SIGKILL)
        assert child.popen.wait(timeout=30) == -signal.SIGKILL
        with pytest.raises(subprocess.TimeoutExpired):
            swarm.spawn("agent 8", "agent", _router_args()).popen.wait(timeout=0.05)


def test_killing_the_fork_server_ends_its_children_and_stop_still_returns() -> None:
    with Swarm() as swarm:
        children = [swarm.spawn(f"agent {i}", "agent", _router_args()) for i in (1, 2, 3)]
        assert swarm.zygote is not None
        server = swarm.zygote.popen
        tree = descendants(server.pid)
        assert sorted(name for name, _ in tree.values()) == ["agent 1", "agent 2", "agent 3"]
        os.kill(server.pid, signal.SIGKILL)
        assert _gone(tree) == {}  # PR_SET_PDEATHSIG: the kernel ended them with the server
        with pytest.raises(ChildFailed, match="agent fork server"):
            swarm.check()
        # The server can no longer report their exits; what ended them is known all the same.
        assert [c.popen.wait(timeout=30) for c in children] == [-signal.SIGTERM] * 3
        with pytest.raises(ChildFailed, match="agent 4: the agent fork server exited"):
            swarm.spawn("agent 4", "agent", _router_args())
        swarm.stop()
