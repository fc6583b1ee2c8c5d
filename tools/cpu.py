"""CPU time of a run's processes over a window of ticks, by kind of process: where a tick's
cost goes, measured the same way for the floor and for the real run (``shoal bench``).

Read from /proc/PID/stat (user + system time of every thread, dead ones included), so the
resolution is the kernel's clock tick (10 ms): over a window of a few hundred ticks that is a
few µs per tick per process. Linux only; elsewhere the figures are simply absent.
"""

from __future__ import annotations

import os
from collections import defaultdict
from collections.abc import Callable, Iterable, Mapping

from tools.procfs import STIME, UTIME, stat_fields
from tools.swarm import Swarm

_TICKS_PER_S = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def cpu_seconds(pid: int) -> float | None:
    """User + system CPU seconds of process ``pid`` so far, or None if it cannot be read."""
    fields = stat_fields(pid)
    return None if fields is None else (int(fields[UTIME]) + int(fields[STIME])) / _TICKS_PER_S


def snapshot(processes: Iterable[tuple[str, int]]) -> dict[int, tuple[str, float]]:
    """pid → (kind, CPU seconds) for each (kind, pid) that can be read now."""
    found = {}
    for kind, pid in processes:
        if (seconds := cpu_seconds(pid)) is not None:
            found[pid] = (kind, seconds)
    return found


def per_tick_us(
    before: Mapping[int, tuple[str, float]], after: Mapping[int, tuple[str, float]], ticks: int
) -> dict[str, float]:
    """CPU µs per tick between two snapshots: for each kind the mean over its processes (an
    agent's figure is one agent's), and ``total`` over every process. Processes missing from
    either snapshot are left out."""
    spent: dict[str, list[float]] = defaultdict(list)
    for pid, (kind, start) in before.items():
        if pid in after:
            spent[kind].append(after[pid][1] - start)
    if ticks <= 0 or not spent:
        return {}
    us = 1e6 / ticks
    figures = {kind: round(sum(v) / len(v) * us, 1) for kind, v in sorted(spent.items())}
    figures["total"] = round(sum(sum(v) for v in spent.values()) * us, 1)
    return figures


class CpuWindow:
    """CPU per tick of a set of processes between :meth:`open` and :meth:`close`."""

    def __init__(self, processes: Callable[[], Iterable[tuple[str, int]]]) -> None:
        self.processes = processes  # (kind, pid) of every process to account, asked each time
        self._before: dict[int, tuple[str, float]] | None = None
        self.figures: dict[str, float] = {}  # per_tick_us(...) once closed

    def open(self) -> None:
        self._before = snapshot(self.processes())

    def close(self, ticks: int) -> dict[str, float]:
        if self._before is not None:
            self.figures = per_tick_us(self._before, snapshot(self.processes()), ticks)
        return self.figures


def swarm_processes(swarm: Swarm, *, monitor: int | None = None) -> list[tuple[str, int]]:
    """(kind, pid) of a swarm's running processes: the kind is the role, except that a
    process named "monitor" is one; the agents' fork server, idle during a run, is left out.
    ``monitor``: a pid to account as the monitor (``shoal run`` follows a run in-process)."""
    found = [
        ("monitor" if c.name == "monitor" else c.role, c.popen.pid)
        for c in swarm.children
        if c.role != "zygote" and c.popen.poll() is None
    ]
    return found + ([("monitor", monitor)] if monitor is not None else [])
