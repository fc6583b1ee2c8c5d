"""CPU accounting per kind of process (tools/cpu.py), as ``shoal bench`` reports it."""

from __future__ import annotations

import os
import resource

import pytest

from tools.cpu import CpuWindow, cpu_seconds, per_tick_us


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
    window = CpuWindow(lambda: [("test", os.getpid())])
    window.open()
    start = cpu_seconds(os.getpid()) or 0.0
    while (cpu_seconds(os.getpid()) or 0.0) - start < 0.2:
        sum(range(10_000))  # burn CPU until the kernel has counted 0.2 s of it
    figures = window.close(ticks=100)
    assert 2000.0 <= figures["test"] <= 2600.0  # 0.2 s (+ a clock tick or two) over 100 ticks
    assert figures["total"] == figures["test"]
