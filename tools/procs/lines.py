"""Lines from a child's pipe with a timeout, read from the raw file descriptor.

A buffered ``readline()`` may take in two lines at once; the second then sits in Python's buffer
where ``select()`` cannot see it, and a caller waiting for it blocks until the child writes again
or exits. Reading the fd ourselves keeps every line we have received visible.
"""

from __future__ import annotations

import os
import select
import time
from typing import IO


class LineReader:
    """The lines a child writes on ``stream`` (a pipe), one at a time."""

    def __init__(self, stream: IO[bytes]) -> None:
        self.stream = stream
        self.ended = False  # the writer has closed its end
        self._buf = b""

    @property
    def exhausted(self) -> bool:
        """The pipe has ended and every line in it has been taken."""
        return self.ended and not self._buf

    def line(self, timeout: float) -> str | None:
        """The next line (without its newline), or None if none is complete within ``timeout``
        seconds or the pipe has ended with nothing left. A last line without a newline is
        returned once the pipe ends."""
        deadline = time.monotonic() + timeout
        fd = self.stream.fileno()
        while b"\n" not in self._buf:
            if self.ended:
                if not self._buf:
                    return None
                last, self._buf = self._buf, b""
                return last.decode(errors="replace")
            left = max(deadline - time.monotonic(), 0.0)
            if not select.select([fd], [], [], left)[0]:
                return None
            chunk = os.read(fd, 65536)
            if chunk:
                self._buf += chunk
            else:
                self.ended = True
        raw, self._buf = self._buf.split(b"\n", 1)
        return raw.decode(errors="replace")
