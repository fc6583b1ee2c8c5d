"""CPU accounting per kind of process (tools/procs/cpu.py), as ``shoal bench`` reports it."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from shoal.tools.procs.cpu import CpuWindow, of_pid, per_tick_us, swarm_processes
from shoal.tools.procs.procfs import cpu_seconds
from shoal.tools.procs.swarm import Child, Swarm


def test_per_tick_figures_are_per_process_means_and_a_total_over_all() -> None:
    before = {1: ("agent", 1.0), 2: ("agent", 2.0), 3: ("world", 0.5), 4: ("router", 0.0)}
    after = {1: ("agent", 1.2), 2: ("agent", 2.4), 3: ("world", 0.6)}  # the router is gone
    figures = per_tick_us(before, after, ticks=1000)
    assert figures == {"agent": pytest.approx(300.0), "world": pytest.approx(100.0),
                       "total": pytest.approx(700.0)}  # fmt: skip


def test_no_ticks_or_no_common_process_gives_no_figures() -> None:
    assert per_tick_us({1: ("agent", 1.0)}, {1: ("agent", 2.0)}, ticks=0) == {}
    assert per_tick_us({1: ("agent", 1.0)}, {2: ("agent", 2.0)}, ticks=10) == {}


def test_a_process_cpu_time_is_read_as_the_kernel_accounts_it() -> None:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    mine = cpu_seconds(os.getpid())
    assert mine is not None
    # Same clock, two readings: /proc counts whole kernel ticks (10 ms), rusage finer.
    assert mine == pytest.approx(usage.ru_utime + usage.ru_stime, abs=0.05)
    assert cpu_seconds(2**22 + 1) is None  # above Linux's pid_max: no such process


def test_a_window_accounts_the_work_done_inside_it() -> None:
    window = CpuWindow(lambda: [of_pid("test", os.getpid())])
    window.open()
    start = cpu_seconds(os.getpid()) or 0.0
    while (cpu_seconds(os.getpid()) or 0.0) - start < 0.2:
        sum(range(10_000))  # burn CPU until the kernel has counted 0.2 s of it
    figures = window.close(ticks=100)
    assert 2000.0 <= figures["test"] <= 2600.0  # 0.2 s (+ a clock tick or two) over 100 ticks
    assert figures["total"] == figures["test"]


BURN = "import sys, time\nsys.stdin.read()\nt = time.process_time()\n" + (
    "while time.process_time() - t < 0.3: pass"
)


def test_a_process_that_exits_inside_the_window_still_counts(tmp_path: Path) -> None:
    """Processes reaped before the window closes (the supervisor polls its children; the
    agents' fork server reaps the agents at once) count with their CPU time at exit: under
    load the last tick is often accounted after the run's processes have ended."""
    with Swarm(log_dir=tmp_path) as swarm:
        burner = subprocess.Popen([sys.executable, "-c", BURN], stdin=subprocess.PIPE)  # ours
        swarm.children.append(Child("burner", burner, tmp_path / "burner.log", "world"))
        swarm.spawn("agent 1", "agent", ["simulate", "sinusoid"])  # forked: the server reaps
        window = CpuWindow(lambda: swarm_processes(swarm))
        window.open()
        assert burner.stdin is not None
        burner.stdin.close()  # go: it burns 0.3 s, exits and is reaped before close
        assert not swarm.expect_exit({"world", "agent"}, timeout=60.0)
        swarm.check()
        figures = window.close(ticks=1000)
    assert set(figures) == {"world", "agent", "total"}
    assert 250.0 <= figures["world"] <= 400.0, figures  # 0.3 s and its exit
    assert figures["agent"] >= 100.0, figures  # a whole simulation: well over 0.1 s
