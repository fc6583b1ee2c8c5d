"""Supervising the processes of a run: spawn, watch, stop in order, never leave orphans.

Each child is a separate OS process (``python -m tools <command>``) in its own session, so a
Ctrl-C reaches only the supervisor, which then stops the children in a safe order: agents and the
world first, the logger after them (so it records everything and finishes its file), the router
last. Children also get SIGTERM from the kernel if the supervisor itself dies (Linux
PR_SET_PDEATHSIG), so not even a SIGKILL of ``shoal run`` leaves orphans. Each child's stderr
goes to its own file, whose tail is shown when it fails.
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
from pathlib import Path
from types import TracebackType
from typing import IO

_PR_SET_PDEATHSIG = 1
_libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)


def _die_with_parent() -> None:  # runs in the child between fork and exec
    _libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


class ChildFailed(RuntimeError):
    """A child exited when it should not have, or never became ready."""


@dataclass
class Child:
    name: str
    popen: subprocess.Popen[bytes]
    log: Path
    role: str  # "agent", "world", "logger", "router"
    done: bool = False  # expected to have exited

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
        role: str,
        args: list[str],
        *,
        ready_pipe: bool = False,
        prefix: Sequence[str] = (),
    ) -> Child:
        """Start ``shoal <args>`` as a child. ``prefix`` goes before the interpreter, e.g.
        ``ip netns exec NS`` to start it on another (namespace) host; the prefix must exec the
        command in place, so that the child's pid, signals and PDEATHSIG stay the command's."""
        log = self.log_dir / f"{name.replace(' ', '-')}.log"
        with log.open("wb") as err:
            popen = subprocess.Popen(
                [*prefix, sys.executable, "-m", "tools", *args],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE if ready_pipe else subprocess.DEVNULL,
                stderr=err,
                start_new_session=True,
                preexec_fn=_die_with_parent,  # safe: no threads exist at spawn time
            )
        child = Child(name, popen, log, role)
        self.children.append(child)
        return child

    def wait_ready(self, child: Child, timeout: float, *, prefix: str = "ready") -> str:
        """Block until ``child`` prints a line starting with ``prefix``; returns that line."""
        stream: IO[bytes] | None = child.popen.stdout
        if stream is None:
            raise ChildFailed(f"{child.name}: spawned without a ready pipe")
        deadline = time.monotonic() + timeout
        while (left := deadline - time.monotonic()) > 0:
            readable, _, _ = select.select([stream], [], [], left)
            if not readable:
                break
            line = stream.readline().decode(errors="replace").strip()
            if line.startswith(prefix):
                return line
            if not line and child.popen.poll() is not None:
                raise ChildFailed(
                    f"{child.name} exited with code {child.popen.returncode} before it was "
                    f"ready:\n{child.tail()}"
                )
        raise ChildFailed(f"{child.name} not ready after {timeout:g} s:\n{child.tail()}")

    def check(self) -> None:
        """Raise if a child has exited that was not expected to."""
        for child in self.children:
            code = child.popen.poll()
            if code is not None and not child.done:
                raise ChildFailed(
                    f"{child.name} exited unexpectedly with code {code}:\n{child.tail()}"
                )

    def expect_exit(self, roles: set[str], timeout: float) -> list[Child]:
        """Mark the children of ``roles`` as allowed to exit and wait for them; returns those
        still running after ``timeout`` seconds."""
        chosen = [c for c in self.children if c.role in roles]
        for c in chosen:
            c.done = True
        deadline = time.monotonic() + timeout
        for c in chosen:
            with contextlib.suppress(subprocess.TimeoutExpired):
                c.popen.wait(timeout=max(deadline - time.monotonic(), 0.01))
        return [c for c in chosen if c.popen.poll() is None]

    def stop(self) -> None:
        """Stop every child still running: agents and world, then logger, then router; each
        group gets SIGTERM, a grace period, then SIGKILL."""
        for roles, grace in (({"agent", "world"}, 5.0), ({"logger"}, 10.0), ({"router"}, 5.0)):
            group = [c for c in self.children if c.role in roles and c.popen.poll() is None]
            for c in group:
                c.done = True
                _signal(c, signal.SIGTERM)
            deadline = time.monotonic() + grace
            for c in group:
                try:
                    c.popen.wait(timeout=max(deadline - time.monotonic(), 0.01))
                except subprocess.TimeoutExpired:
                    _signal(c, signal.SIGKILL)
                    c.popen.wait()
        for c in self.children:
            if c.popen.stdout is not None:
                c.popen.stdout.close()
        shutil.rmtree(self.log_dir, ignore_errors=True)


def _signal(child: Child, sig: int) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.kill(child.popen.pid, sig)
