"""The supervisor's side of the agent fork server (tools/zygote.py): ask it to fork, and follow
the exits it reports. Kept apart from the server, which imports numpy and zenoh."""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import subprocess
import time
from typing import IO


class ForkServerGone(RuntimeError):
    """The fork server ended (or stopped answering) while it still owed an answer."""


class Zygote:
    """The supervisor's handle on a running fork server: fork requests and exit reports."""

    def __init__(self, popen: subprocess.Popen[bytes], log: str) -> None:
        self.popen = popen  # with stdin and stdout pipes
        self.log = log  # the server's own stderr, for the error when it fails
        self.codes: dict[int, int] = {}  # pid → exit code, as reported
        self._buf = b""
        self._pids: list[int] = []  # answers to fork requests not yet taken

    def fork(self, name: str, args: list[str], log: str, timeout: float = 60.0) -> Forked:
        """Fork ``shoal <args>`` (stderr to ``log``); returns once its pid is known."""
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
        while not self._pids:
            left = deadline - time.monotonic()
            if left <= 0:
                raise ForkServerGone(self._why(f"did not fork within {timeout:g} s"))
            if self._line(left) is None and self._ended():
                raise ForkServerGone(self._why("exited"))
        return Forked(self, self._pids.pop(0), args)

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
        while not self._ended() and time.monotonic() < deadline:
            self._line(max(deadline - time.monotonic(), 0.0))

    def _close_stdin(self) -> None:
        stdin = self.popen.stdin
        if stdin is not None and not stdin.closed:
            with contextlib.suppress(BrokenPipeError):  # unsent bytes of a server that is gone
                stdin.close()

    def _ended(self) -> bool:
        """Whether the server's stdout is at its end (it exited) with nothing left unread."""
        stream = self.popen.stdout
        return stream is None or stream.closed

    def _why(self, what: str) -> str:
        try:
            with open(self.log, errors="replace") as f:
                tail = "".join(f.readlines()[-12:])
        except OSError:
            tail = ""
        return f"the agent fork server {what}:\n{tail}".rstrip()

    def _line(self, timeout: float) -> str | None:
        """One line from the server (pid and exit reports are recorded), or None if there is
        none within ``timeout`` s or the stream has ended."""
        stream = self.popen.stdout
        while b"\n" not in self._buf:
            if stream is None or stream.closed:
                return None
            if not select.select([stream.fileno()], [], [], timeout)[0]:
                return None
            chunk = os.read(stream.fileno(), 65536)
            if not chunk:
                stream.close()
                return None
            self._buf += chunk
        raw, self._buf = self._buf.split(b"\n", 1)
        line = raw.decode(errors="replace")
        word, *rest = line.split() or [""]
        if word == "pid":
            self._pids.append(int(rest[0]))
        elif word == "exit":
            self.codes[int(rest[0])] = int(rest[1])
        return line


class Forked:
    """A process forked by the server, with the part of ``subprocess.Popen`` that the
    supervisor and the tests use: ``pid``, ``poll``, ``wait``, ``returncode``, ``stdout``."""

    stdout: IO[bytes] | None = None  # a forked child never has a ready pipe

    def __init__(self, zygote: Zygote, pid: int, args: list[str]) -> None:
        self.zygote = zygote
        self.pid = pid
        self.args = args

    @property
    def returncode(self) -> int | None:
        return self.zygote.codes.get(self.pid)

    def poll(self) -> int | None:
        if self.returncode is None:
            self.zygote.pump(0.0)
        if self.returncode is None and self.zygote._ended() and not self._exists():
            # The server died before it could report this exit; its death is what ended the
            # process (PR_SET_PDEATHSIG sends SIGTERM), so that is the code it is given.
            self.zygote.codes[self.pid] = -signal.SIGTERM
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        deadline = None if timeout is None else time.monotonic() + timeout
        while (code := self.poll()) is None:
            left = 1.0 if deadline is None else deadline - time.monotonic()
            if left <= 0:
                raise subprocess.TimeoutExpired(self.args, timeout or 0.0)
            if self.zygote._ended():  # no more reports: look at the process itself
                _pause(min(left, 0.01))
            else:
                self.zygote.pump(min(left, 1.0))
        return code

    def _exists(self) -> bool:
        """Whether the pid still names a live process (orphaned, it is reaped by init)."""
        try:
            with open(f"/proc/{self.pid}/stat") as f:
                return f.read().rsplit(")", 1)[1].split()[0] != "Z"
        except (OSError, IndexError):
            return False


def _pause(seconds: float) -> None:
    """Wait a little between looks at /proc; nothing else can wake us when the server is
    gone (the process is no child of ours)."""
    select.select([], [], [], seconds)
