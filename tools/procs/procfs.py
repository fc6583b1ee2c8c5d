"""Reading /proc/PID/stat (Linux): the one parser for the fields the tools and tests need."""

from __future__ import annotations

import os

STATE, PPID, UTIME, STIME, START_TIME = 0, 1, 11, 12, 19  # indices in stat_fields(pid)


def stat_fields(pid: int) -> list[str] | None:
    """/proc/PID/stat's fields after the command name (the state first), or None if there is
    no such process. The name is skipped by its closing parenthesis: it may hold spaces."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            text = f.read()
    except OSError:
        return None
    return text[text.rfind(")") + 2 :].split()


_TICKS_PER_S = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of process ``pid`` so far (of every thread, dead ones
    included; a zombie keeps its final figure), or None if it cannot be read."""
    fields = stat_fields(pid)
    return None if fields is None else (int(fields[UTIME]) + int(fields[STIME])) / _TICKS_PER_S
