"""CPU time of a run's processes over a window of ticks, by kind of process: where a tick's
cost goes, measured the same way for the floor and for the real run (``shoal bench``).

Read from /proc/PID/stat (user + system time of every thread, dead ones included), so the
resolution is the kernel's clock tick (10 ms): over a window of a few hundred ticks that is a
few µs per tick per process. Linux only; elsewhere the figures are simply absent.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Hashable, Iterable, Mapping
from typing import TypeVar

from shoal.tools.procs.procfs import cpu_seconds
from shoal.tools.procs.swarm import Swarm

Reader = Callable[[], "float | None"]  # CPU seconds of one process so far, None if unknown
Process = tuple[str, Hashable, Reader]  # (kind, a key naming it, its reader)
K = TypeVar("K", bound=Hashable)


def of_pid(kind: str, pid: int) -> Process:
    """A process read from /proc by its pid (while it runs, or as a zombie)."""
    return kind, pid, lambda: cpu_seconds(pid)


def snapshot(processes: Iterable[Process]) -> dict[Hashable, tuple[str, float]]:
    """key → (kind, CPU seconds) for each process that can be read now."""
    found = {}
    for kind, key, read in processes:
        if (seconds := read()) is not None:
            found[key] = (kind, seconds)
    return found


def per_tick_us(
    before: Mapping[K, tuple[str, float]],
    after: Mapping[K, tuple[str, float]],
    ticks: int,
) -> dict[str, float]:
    """CPU µs per tick between two snapshots: for each kind the mean over its processes (an
    agent's figure is one agent's), and ``total`` over every process. Processes missing from
    either snapshot are left out."""
    spent: dict[str, list[float]] = defaultdict(list)
    for key, (kind, start) in before.items():
        if key in after:
            spent[kind].append(after[key][1] - start)
    if ticks <= 0 or not spent:
        return {}
    us = 1e6 / ticks
    figures = {kind: round(sum(v) / len(v) * us, 1) for kind, v in sorted(spent.items())}
    figures["total"] = round(sum(sum(v) for v in spent.values()) * us, 1)
    return figures


class CpuWindow:
    """CPU per tick of a set of processes between :meth:`open` and :meth:`close`. The
    processes are the ones found at :meth:`open`; one that exits before :meth:`close` still
    counts, with the CPU time it had at its exit (its reader must know that figure)."""

    def __init__(self, processes: Callable[[], Iterable[Process]]) -> None:
        self.processes = processes  # the processes to account, asked at open
        self._found: list[Process] = []
        self._before: dict[Hashable, tuple[str, float]] | None = None
        self.figures: dict[str, float] = {}  # per_tick_us(...) once closed

    def open(self) -> None:
        self._found = list(self.processes())
        self._before = snapshot(self._found)

    def close(self, ticks: int) -> dict[str, float]:
        if self._before is not None:
            self.figures = per_tick_us(self._before, snapshot(self._found), ticks)
        return self.figures


def swarm_processes(swarm: Swarm, *, monitor: int | None = None) -> list[Process]:
    """The processes of a swarm still running: the kind is the role, except that a process
    named "monitor" is one; the agents' fork server, idle during a run, is left out.
    ``monitor``: a pid to account as the monitor (``shoal run`` follows a run in-process)."""
    found: list[Process] = [
        ("monitor" if c.name == "monitor" else c.role, id(c), c.cpu_seconds)
        for c in swarm.children
        if c.role != "zygote" and c.poll() is None
    ]
    return found + ([of_pid("monitor", monitor)] if monitor is not None else [])
