"""The supervisor's side of the agent fork server (tools/procs/zygote.py): ask it to fork, and
follow the exits it reports. Kept apart from the server, which imports numpy and zenoh.

A pid names a process only until that process is reaped; the server reaps, so the supervisor
knows a forked process by its pid *and* its start time, and an exit report goes to the process
that was forked under that pid, never to a later one that reuses it.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import time
from typing import IO

from shoal.tools.procs.lines import LineReader
from shoal.tools.procs.procfs import START_TIME, STATE, stat_fields


class ForkServerGone(RuntimeError):
    """The fork server ended, stopped answering, or could not fork."""


def start_time(pid: int) -> str | None:
    """When process ``pid`` started (clock ticks since boot, as /proc gives it), or None if
    there is no such live process (gone, or a zombie)."""
    fields = stat_fields(pid)
    return None if fields is None or fields[STATE] == "Z" else fields[START_TIME]


class Zygote:
    """The supervisor's handle on a running fork server: fork requests and exit reports."""

    def __init__(self, popen: subprocess.Popen[bytes], log: str) -> None:
        assert popen.stdin is not None and popen.stdout is not None
        self.popen = popen  # with stdin and stdout pipes
        self.log = log  # the server's own stderr, for the error when it fails
        self._reader = LineReader(popen.stdout)
        self._answers: list[tuple[str, str]] = []  # ("pid", PID) or ("error", why), in order
        self._live: dict[int, Forked] = {}  # pid → the process forked under it, until it exits

    def fork(self, name: str, args: list[str], log: str, timeout: float = 60.0) -> Forked:
        """Fork ``shoal <args>`` (stderr to ``log``); returns once the child is set up."""
        stdin: IO[bytes] | None = self.popen.stdin
        if stdin is None or stdin.closed:
            raise ForkServerGone("the agent fork server is closed")
        try:
            stdin.write(json.dumps({"name": name, "args": args, "log": log}).encode() + b"\n")
            stdin.flush()
        except BrokenPipeError:
            self._close_stdin()
            raise ForkServerGone(self._why("exited")) from None
        deadline = time.monotonic() + timeout
        while not self._answers:
            left = deadline - time.monotonic()
            if left <= 0:
                # A late answer would be taken for the next request's: stop using the server.
                self._close_stdin()
                raise ForkServerGone(self._why(f"did not fork within {timeout:g} s"))
            if self._line(left) is None and self.ended():
                raise ForkServerGone(self._why("exited"))
        word, text = self._answers.pop(0)
        if word == "error":
            raise ForkServerGone(f"the agent fork server could not fork {name}: {text}")
        child = Forked(self, int(text), args)
        self._live[child.pid] = child  # before any later line: its exit report comes after
        return child

    def pump(self, timeout: float) -> None:
        """Take in everything the server has said, waiting at most ``timeout`` s for a line."""
        if self._line(timeout) is not None:
            while self._line(0.0) is not None:
                pass

    def close(self, timeout: float = 5.0) -> None:
        """Let the server go: it exits when its stdin closes (its children, if any are left,
        get SIGTERM from the kernel); read what it still had to say."""
        self._close_stdin()
        deadline = time.monotonic() + timeout
        while not self.ended() and time.monotonic() < deadline:
            self._line(max(deadline - time.monotonic(), 0.0))

    def ended(self) -> bool:
        """Whether the server's stdout has ended (it exited) with nothing left unread."""
        return self._reader.exhausted

    def _close_stdin(self) -> None:
        stdin = self.popen.stdin
        if stdin is not None and not stdin.closed:
            with contextlib.suppress(BrokenPipeError):  # unsent bytes of a server that is gone
                stdin.close()

    def _why(self, what: str) -> str:
        try:
            with open(self.log, errors="replace") as f:
                tail = "".join(f.readlines()[-12:])
        except OSError:
            tail = ""
        return f"the agent fork server {what}:\n{tail}".rstrip()

    def _line(self, timeout: float) -> str | None:
        """One line from the server, taken into account, or None if there is none within
        ``timeout`` s or its stdout has ended."""
        line = self._reader.line(timeout)
        if line is None:
            return None
        word, _, rest = line.partition(" ")
        if word in ("pid", "error"):
            self._answers.append((word, rest))
        elif word == "exit":
            pid, code, cpu = rest.split()
            child = self._live.pop(int(pid), None)
            if child is not None:  # None: the child of a request abandoned (the server closed)
                child.cpu_at_exit = float(cpu)
                child.code = int(code)
        return line


class Forked:
    """A process forked by the server, with the part of ``subprocess.Popen`` that the
    supervisor and the tests use: ``pid``, ``poll``, ``wait``, ``send_signal``, ``returncode``,
    ``stdout``."""

    stdout: IO[bytes] | None = None  # a forked child never has a ready pipe

    def __init__(self, zygote: Zygote, pid: int, args: list[str]) -> None:
        self.zygote = zygote
        self.pid = pid
        self.args = args
        self.code: int | None = None  # as reported by the server
        self.cpu_at_exit: float | None = None  # user + system seconds, reported with the code
        self.started = start_time(pid)  # tells this process from a later one with its pid

    @property
    def returncode(self) -> int | None:
        return self.code

    def poll(self) -> int | None:
        if self.code is None:
            self.zygote.pump(0.0)
        if self.code is None and self.zygote.ended() and not self.alive():
            # The server died before it could report this exit. Its death is what ends its
            # children (PR_SET_PDEATHSIG sends SIGTERM), so that is the code given; a child
            # that had ended by itself just before is reported the same way.
            self.code = -signal.SIGTERM
        return self.code

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while (code := self.poll()) is None:
            left = 1.0 if deadline is None else deadline - time.monotonic()
            if left <= 0:
                raise subprocess.TimeoutExpired(self.args, timeout or 0.0)
            if self.zygote.ended():  # no more reports: look at the process itself
                select.select([], [], [], min(left, 0.01))  # nothing else can wake us
            else:
                self.zygote.pump(min(left, 1.0))
        return code

    def send_signal(self, sig: int) -> None:
        """Signal the process if it is still the one forked (not a later one with its pid)."""
        if self.poll() is None and self.alive():
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, sig)

    def alive(self) -> bool:
        """Whether the pid still names this process, running (not a zombie, not reused)."""
        return self.started is not None and start_time(self.pid) == self.started
