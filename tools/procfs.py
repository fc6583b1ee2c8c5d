"""Reading /proc/PID/stat (Linux): the one parser for the fields the tools and tests need."""

from __future__ import annotations

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
