"""Supervising the processes of a run: spawn, watch, stop in order, never leave orphans.

Each child is a separate OS process (``python -m tools <command>``) in its own session, so a
Ctrl-C reaches only the supervisor, which then stops the children in a safe order: agents and the
world first, the logger after them (so it records everything and finishes its file), the router
last. Children also get SIGTERM from the kernel if the supervisor itself dies (Linux
PR_SET_PDEATHSIG), so not even a SIGKILL of ``shoal run`` leaves orphans. Each child's stderr
goes to its own file, whose tail is shown when it fails. Agents are forked from a fork server
that has imported their code once (tools/procs/zygote.py), under the same guarantees.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from types import TracebackType
from typing import IO

from shoal.tools.procs.forks import Forked, ForkServerGone, Zygote
from shoal.tools.procs.lines import LineReader
from shoal.tools.procs.procfs import cpu_seconds

_PR_SET_PDEATHSIG = 1
_PR_SET_NAME = 15
_libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)


SUPERVISOR_ENV = "SHOAL_SUPERVISOR_PID"  # set for a child by the Swarm that starts it


def die_with(parent: int, sig: signal.Signals = signal.SIGTERM) -> None:
    """In a child: ask the kernel for ``sig`` when the parent thread dies, and leave at once
    if the parent is no longer ``parent`` (it died before the request took effect)."""
    _libc.prctl(_PR_SET_PDEATHSIG, sig)
    if os.getppid() != parent:
        os._exit(1)


def adopt_supervisor() -> None:
    """First thing in a process a Swarm started: die with the supervisor (SIGTERM when it
    dies), and leave at once if it has died already, before this line. Done by the child
    itself rather than between fork and exec, which is unsafe in a supervisor with threads (a
    test process with Zenoh sessions open). The variable is taken out of the environment, so
    that processes this one starts do not act on it."""
    supervisor = os.environ.pop(SUPERVISOR_ENV, None)
    if supervisor is not None:
        die_with(int(supervisor))


def name_process(name: str) -> None:
    """Name this process for ``top`` and ``ps -o comm`` (the kernel keeps 15 bytes)."""
    _libc.prctl(_PR_SET_NAME, name.encode()[:15], 0, 0, 0)


# Stop order: each group gets SIGTERM, then this many seconds, then SIGKILL.
class Role(StrEnum):
    """What a child process of a swarm is."""

    AGENT = "agent"
    WORLD = "world"
    LOGGER = "logger"
    ROUTER = "router"
    ZYGOTE = "zygote"  # the agents' fork server
    GUARD = "guard"  # stops ROS 2 robots if the world dies (tools/commands/guard.py)


STOP_ORDER = (
    ({Role.AGENT, Role.WORLD}, 5.0),
    ({Role.LOGGER, Role.GUARD}, 10.0),  # the guard sends its stops when it goes
    ({Role.ROUTER, Role.ZYGOTE}, 5.0),
)
# What a supervisor (shoal run, shoal bench) may take to stop after SIGTERM/SIGINT before its
# own watchdog ends it (bus/runtime.py, exit_on_signals): every group's grace, and a margin.
SUPERVISOR_GRACE_S = int(sum(grace for _, grace in STOP_ORDER)) + 10


class ChildFailed(RuntimeError):
    """A child exited when it should not have, or never became ready."""


@dataclass
class Child:
    name: str
    popen: subprocess.Popen[bytes] | Forked
    log: Path
    role: Role
    done: bool = False  # expected to have exited
    reader: LineReader | None = None  # its ready pipe's lines, once waited on
    cpu_at_exit: float | None = None  # user + system seconds, taken just before it was reaped

    def poll(self) -> int | None:
        """Its exit code, or None while it runs. A process of ours that has exited has its
        final CPU time read before it is reaped (after that its /proc entry is gone); the
        fork server reports a forked one's with its exit."""
        popen = self.popen
        if isinstance(popen, subprocess.Popen) and popen.returncode is None:
            with contextlib.suppress(AttributeError, OSError):  # no waitid (macOS): no figure
                flags = os.WEXITED | os.WNOHANG | os.WNOWAIT  # look, do not reap
                if os.waitid(os.P_PID, popen.pid, flags) is not None:
                    self.cpu_at_exit = cpu_seconds(popen.pid)
        return popen.poll()

    def wait(self, timeout: float) -> int:
        """Wait at most ``timeout`` s for it to exit (subprocess.TimeoutExpired if it does
        not); like :meth:`poll`, a process of ours has its final CPU time read first."""
        popen = self.popen
        if isinstance(popen, subprocess.Popen) and popen.returncode is None:
            with contextlib.suppress(AttributeError, OSError):  # no pidfd: plain wait
                fd = os.pidfd_open(popen.pid)
                try:
                    select.select([fd], [], [], max(timeout, 0.0))  # readable once it exits
                finally:
                    os.close(fd)
                if self.poll() is None:
                    raise subprocess.TimeoutExpired(popen.args, timeout)
        return popen.wait(timeout=timeout)

    def cpu_seconds(self) -> float | None:
        """User + system CPU seconds so far, the final figure once it has exited, or None if
        that is unknown (the figure of a process reaped unseen, or not readable here)."""
        popen = self.popen
        if isinstance(popen, Forked):
            return popen.cpu_at_exit if popen.poll() is not None else cpu_seconds(popen.pid)
        return self.cpu_at_exit if popen.returncode is not None else cpu_seconds(popen.pid)

    def tail(self, lines: int = 12) -> str:
        try:
            text = self.log.read_text(errors="replace").strip().splitlines()
        except OSError:
            return ""
        return "\n".join(text[-lines:])


@dataclass
class Swarm:
    """The children of one run; a context manager that always stops them all."""

    log_dir: Path = field(default_factory=lambda: Path(tempfile.mkdtemp(prefix="shoal-run-")))
    children: list[Child] = field(default_factory=list)
    fork_agents: bool = True  # fork agents from one process that has imported them already
    zygote: Zygote | None = None
    reaper: subprocess.Popen[bytes] | None = None  # removes log_dir if we cannot (reaper.py)

    def __post_init__(self) -> None:
        self.reaper = subprocess.Popen(
            [sys.executable, "-m", "shoal.tools.procs.reaper", str(self.log_dir)],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            start_new_session=True,  # not in our process group: a Ctrl-C is not for it
        )

    def __enter__(self) -> Swarm:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()

    def spawn(
        self,
        name: str,
        role: Role | str,
        args: list[str],
        *,
        ready_pipe: bool = False,
        prefix: Sequence[str] = (),
    ) -> Child:
        """Start ``shoal <args>`` as a child. ``prefix`` goes before the interpreter, e.g.
        ``ip netns exec NS`` to start it on another (namespace) host; the prefix must exec the
        command in place, so that the child's pid, signals and PDEATHSIG stay the command's.
        An agent on this host is forked from the fork server instead (``fork_agents``)."""
        log = self.log_dir / f"{name.replace(' ', '-')}.log"
        popen: subprocess.Popen[bytes] | Forked
        if role == "agent" and self.fork_agents and not prefix and not ready_pipe:
            try:
                popen = self._fork_server(args).fork(name, args, str(log))
            except ForkServerGone as exc:
                raise ChildFailed(f"{name}: {exc}") from None
        else:
            stdout = subprocess.PIPE if ready_pipe else subprocess.DEVNULL
            command = [*prefix, sys.executable, "-m", "shoal.tools", *args]
            popen = _start(command, log, stdin=subprocess.DEVNULL, stdout=stdout)
        child = Child(name, popen, log, Role(role))
        self.children.append(child)
        return child

    def _fork_server(self, args: list[str]) -> Zygote:
        """The fork server, started on first use. Its command line (which forked agents show
        too) carries the run id of the first agent, so that ``pgrep -f -- '--run RUN'`` finds
        every process of a run."""
        if self.zygote is None:
            log = self.log_dir / "agent-fork-server.log"
            at = args.index("--run") if "--run" in args[:-1] else None
            label = [] if at is None else args[at : at + 2]
            command = [sys.executable, "-m", "shoal.tools.procs.zygote", *label]
            popen = _start(command, log, stdin=subprocess.PIPE, stdout=subprocess.PIPE)
            self.children.append(Child("agent fork server", popen, log, Role.ZYGOTE))
            self.zygote = Zygote(popen, str(log))
        return self.zygote

    def wait_ready(self, child: Child, timeout: float, *, prefix: str = "ready") -> str:
        """Block until ``child`` prints a line starting with ``prefix``; returns that line."""
        stream: IO[bytes] | None = child.popen.stdout
        if stream is None:
            raise ChildFailed(f"{child.name}: spawned without a ready pipe")
        if child.reader is None:
            child.reader = LineReader(stream)
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            line = child.reader.line(left)
            if line is not None and line.strip().startswith(prefix):
                return line.strip()
            if child.reader.exhausted:  # it closed its stdout: it is exiting, or has
                with contextlib.suppress(subprocess.TimeoutExpired):
                    child.popen.wait(timeout=max(deadline - time.monotonic(), 0.1))
                code = child.popen.returncode
                raise ChildFailed(
                    f"{child.name} exited with code {code} before it was ready:\n{child.tail()}"
                )
        raise ChildFailed(f"{child.name} not ready after {timeout:g} s:\n{child.tail()}")

    def check(self) -> None:
        """Raise if a child has exited that was not expected to."""
        exited = [(c, c.poll()) for c in self.children if not c.done]
        # A failure first: a logger that finished cleanly because the world died is the
        # consequence, the world's error (exit 1, its reason in its tail) the cause.
        exited = sorted(((c, code) for c, code in exited if code is not None),
                        key=lambda e: e[1] == 0)  # fmt: skip
        for child, code in exited:
            raise ChildFailed(f"{child.name} exited unexpectedly with code {code}:\n{child.tail()}")

    def expect_exit(self, roles: set[str], timeout: float) -> list[Child]:
        """Mark the children of ``roles`` as allowed to exit and wait for them; returns those
        still running after ``timeout`` seconds."""
        chosen = [c for c in self.children if c.role in roles]
        for c in chosen:
            c.done = True
        deadline = time.monotonic() + timeout
        for c in chosen:
            with contextlib.suppress(subprocess.TimeoutExpired):
                c.wait(timeout=max(deadline - time.monotonic(), 0.01))
        return [c for c in chosen if c.poll() is None]

    def stop(self) -> None:
        """Stop every child still running: agents and world, then logger, then router (and the
        agents' fork server); each group gets SIGTERM, a grace period, then SIGKILL."""
        for roles, grace in STOP_ORDER:
            if "zygote" in roles and self.zygote is not None:
                self.zygote.close()  # it leaves when its stdin closes; SIGTERM if it does not
            group = [c for c in self.children if c.role in roles and c.poll() is None]
            for c in group:
                c.done = True
                _signal(c, signal.SIGTERM)
            deadline = time.monotonic() + grace
            for c in group:
                try:
                    c.wait(timeout=max(deadline - time.monotonic(), 0.01))
                except subprocess.TimeoutExpired:
                    _signal(c, signal.SIGKILL)
                    c.popen.wait()
        for c in self.children:
            if c.popen.stdout is not None:
                c.popen.stdout.close()
        shutil.rmtree(self.log_dir, ignore_errors=True)
        reaper, self.reaper = self.reaper, None
        if reaper is not None and reaper.stdin is not None:
            reaper.stdin.close()  # the folder is gone: it finds nothing to do and leaves
            try:
                reaper.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                reaper.kill()
                reaper.wait()


def _start(command: list[str], log: Path, *, stdin: int, stdout: int) -> subprocess.Popen[bytes]:
    """A child in its own session, stderr to ``log``, that dies with us (adopt_supervisor)."""
    with log.open("wb") as err:
        return subprocess.Popen(
            command,
            stdin=stdin,
            stdout=stdout,
            stderr=err,
            start_new_session=True,
            env={**os.environ, SUPERVISOR_ENV: str(os.getpid())},
        )


def _signal(child: Child, sig: int) -> None:
    with contextlib.suppress(ProcessLookupError):
        child.popen.send_signal(sig)  # neither kind signals a pid it no longer owns
