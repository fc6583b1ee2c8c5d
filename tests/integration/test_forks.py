"""The agents' fork server (tools/procs/zygote.py, tools/procs/forks.py) with real processes: what a
forked process reports, and that no way of ending the server leaves one of them behind."""

from __future__ import annotations

import os
import signal
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import descendants, still_running_after

from shoal.tools.procs.forks import Forked, ForkServerGone, Zygote
from shoal.tools.procs.launch import free_port
from shoal.tools.procs.lines import LineReader
from shoal.tools.procs.swarm import ChildFailed, Swarm


def _router_args() -> list[str]:
    """A command that runs until SIGTERM: a Zenoh router on a free loopback port."""
    return ["router", "--listen", f"tcp/127.0.0.1:{free_port()}"]


def _name(pid: int) -> str:
    return Path(f"/proc/{pid}/comm").read_text().strip()


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
        # PR_SET_PDEATHSIG: the kernel ends them with the server. 30 s: more than the 10 s
        # watchdog of a process that hangs while stopping (bus/runtime.py).
        assert still_running_after(tree, 30.0) == {}
        with pytest.raises(ChildFailed, match="agent fork server"):
            swarm.check()
        # The server can no longer report their exits: each wait ends all the same.
        for c in children:
            c.popen.wait(timeout=30)
        with pytest.raises(ChildFailed, match="agent 4: the agent fork server exited"):
            swarm.spawn("agent 4", "agent", _router_args())
        swarm.stop()


def test_the_server_survives_a_request_it_cannot_serve_and_keeps_forking() -> None:
    with Swarm() as swarm:
        swarm.spawn("agent 1", "agent", ["scenarios"])
        assert swarm.zygote is not None and swarm.zygote.popen.stdin is not None
        swarm.zygote.popen.stdin.write(b"this is not json\n")  # answered by an error line
        with pytest.raises(ChildFailed, match="could not fork agent 2: JSONDecodeError"):
            swarm.spawn("agent 2", "agent", ["scenarios"])
        assert swarm.spawn("agent 3", "agent", ["scenarios"]).popen.wait(timeout=30) == 0


# -- the client against a scripted server: pid reuse and late answers -----------------------------


class _Scripted:
    """Stands in for the server's Popen: what the test writes to ``say`` is the server's
    output; requests go to /dev/null."""

    def __init__(self) -> None:
        r, w = os.pipe()
        self.stdout = os.fdopen(r, "rb", buffering=0)
        self._w = w
        self.stdin = open(os.devnull, "wb")  # noqa: SIM115 (closed by close())

    def say(self, *lines: str) -> None:
        os.write(self._w, "".join(f"{line}\n" for line in lines).encode())

    def close(self) -> None:
        os.close(self._w)
        self.stdout.close()
        self.stdin.close()


@pytest.fixture
def scripted() -> Iterator[tuple[_Scripted, Zygote]]:
    server = _Scripted()
    yield server, Zygote(server, os.devnull)  # type: ignore[arg-type]
    server.close()


def test_an_exit_report_goes_to_the_process_forked_under_that_pid_not_to_a_later_one(
    scripted: tuple[_Scripted, Zygote],
) -> None:
    server, zygote = scripted
    server.say("pid 4242")
    first = zygote.fork("agent 1", [], os.devnull)
    server.say("exit 4242 0 0.5", "pid 4242")  # it ended, and a new child got its pid
    second = zygote.fork("agent 2", [], os.devnull)
    assert (first.pid, second.pid) == (4242, 4242)
    assert first.poll() == 0
    assert second.poll() is None
    server.say("exit 4242 -9 0.25")
    assert second.wait(timeout=5) == -9 and first.returncode == 0
    assert (first.cpu_at_exit, second.cpu_at_exit) == (0.5, 0.25)  # its own, not the later one's


def test_after_a_fork_times_out_the_server_is_not_used_again(
    scripted: tuple[_Scripted, Zygote],
) -> None:
    server, zygote = scripted
    with pytest.raises(ForkServerGone, match=r"did not fork within 0\.05 s"):
        zygote.fork("agent 1", [], os.devnull, timeout=0.05)
    server.say("pid 111")  # the late answer must not become agent 2's pid
    with pytest.raises(ForkServerGone, match="closed"):
        zygote.fork("agent 2", [], os.devnull)


def test_a_pid_that_names_another_process_now_is_never_signalled(
    scripted: tuple[_Scripted, Zygote],
) -> None:
    _, zygote = scripted
    with subprocess.Popen(["sleep", "60"]) as stranger:
        try:
            forked = Forked(zygote, stranger.pid, [])
            assert forked.alive()
            forked.started = "0"  # as if ours had ended and the pid had been reused
            assert not forked.alive()
            forked.send_signal(signal.SIGKILL)
            with pytest.raises(subprocess.TimeoutExpired):
                stranger.wait(timeout=0.2)  # the stranger lives on
        finally:
            stranger.kill()


def test_two_lines_that_arrive_together_are_both_seen_at_once() -> None:
    r, w = os.pipe()
    with os.fdopen(r, "rb", buffering=0) as stream:
        reader = LineReader(stream)
        os.write(w, b'ready floor ticking\n{"ticks": 60}\n')
        assert reader.line(timeout=5) == "ready floor ticking"
        assert reader.line(timeout=0) == '{"ticks": 60}'  # already here: no waiting for more
        assert reader.line(timeout=0) is None and not reader.ended
        os.write(w, b"last words")
        os.close(w)
        assert reader.line(timeout=5) == "last words"
        assert reader.line(timeout=5) is None and reader.exhausted
