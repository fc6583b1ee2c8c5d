"""What reaches the controller in realtime: freshness of neighbour states, injected loss."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner
from conftest import shortened

from shoal.agent.delivery import MAX_AGE, AgeStats, Dropper, freshest
from shoal.bus.messages import AgentState
from shoal.tools.cli import main


def state(j: int, tick: int) -> AgentState:
    return AgentState(j, tick, (float(j), 0.0), False, 1.0, 1.0, 0.0)


def test_freshest_uses_states_up_to_max_age_and_reports_every_age() -> None:
    latest = {2: state(2, 100), 3: state(3, 90), 4: state(4, 89), 5: state(5, 101)}
    used, ages = freshest(latest, [2, 3, 4, 5, 6], now=100, max_age=10)
    assert set(used) == {2, 3, 5}  # 4 is 11 ticks old; 6 was never heard
    assert ages == {2: 0, 3: 10, 4: 11, 5: 0}  # a state of the next tick counts as age 0
    assert used[3] is latest[3]


def test_freshest_only_looks_at_the_neighbours_asked_for() -> None:
    used, ages = freshest({2: state(2, 5), 3: state(3, 5)}, [3], now=5, max_age=MAX_AGE)
    assert set(used) == set(ages) == {3}


def test_dropper_is_seeded_per_agent_and_counts_at_the_rate() -> None:
    a, b, c = Dropper(0.2, 7, 1), Dropper(0.2, 7, 1), Dropper(0.2, 7, 2)
    da = [a.drop() for _ in range(20000)]
    assert da == [b.drop() for _ in range(20000)]  # same seed and agent: same sequence
    assert da != [c.drop() for _ in range(20000)]  # another agent draws its own
    assert a.offered == 20000 and a.dropped == sum(da)
    assert abs(a.dropped / a.offered - 0.2) < 0.015  # 5 standard deviations: 0.014


def test_dropper_at_zero_never_drops_and_refuses_a_rate_of_one() -> None:
    d = Dropper(0.0, 0, 1)
    assert not any(d.drop() for _ in range(1000)) and d.offered == 1000
    with pytest.raises(ValueError, match="drop rate"):
        Dropper(1.0, 0, 1)


def test_age_stats_histogram_quantiles_and_stale_edges() -> None:
    s = AgeStats()
    assert s.quantile(0.5) is None
    s.add({2: 0, 3: 1}, max_age=10)
    s.add({2: 1, 3: 12}, max_age=10)
    s.add({2: 3}, max_age=10)
    assert s.histogram == {0: 1, 1: 2, 3: 1} and s.stale_edges == 1
    assert s.quantile(0.5) == 1 and s.quantile(0.99) == 3


def test_shoal_run_refuses_drops_in_lockstep() -> None:
    result = CliRunner().invoke(main, ["run", "sinusoid", "--drop-rate", "0.1"])
    assert result.exit_code == 2
    assert "--drop-rate" in result.output and "realtime" in result.output


def test_shoal_run_refuses_a_speed_in_lockstep_as_it_refuses_drops() -> None:
    result = CliRunner().invoke(main, ["run", "sinusoid", "--speed", "2"])
    assert result.exit_code == 2
    assert "--speed" in result.output and "realtime" in result.output


def test_the_old_mode_option_still_works_and_says_its_new_name() -> None:
    """`--clock` is the word the summary and the docs use; `--mode` stays for old scripts."""
    result = CliRunner().invoke(main, ["run", "sinusoid", "--mode", "lockstep", "--speed", "2"])
    assert result.exit_code == 2, result.output
    assert "--mode is now --clock" in result.stderr
    assert "needs --clock realtime" in result.output


def test_injected_drops_are_reported_by_shoal_run(tmp_path: Path) -> None:
    """--drop-rate's drops, counted by every agent, are totalled in the run's summary."""
    scenario = shortened(tmp_path, "sinusoid", 1.0)
    result = CliRunner().invoke(
        main,
        ["run", str(scenario), "--clock", "realtime", "--drop-rate", "0.3", "--json",
         "--no-foxglove", "--out", str(tmp_path / "run.mcap")],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    drops = json.loads(result.stdout)["injected_drops"]
    assert drops["agents"] == 5 and drops["offered"] > 100
    assert 0.2 < drops["dropped"] / drops["offered"] < 0.4  # seeded draws at p = 0.3
    text = CliRunner().invoke(
        main,
        ["run", str(scenario), "--clock", "realtime", "--drop-rate", "0.3", "--no-foxglove",
         "--out", str(tmp_path / "again.mcap")],
    )  # fmt: skip
    assert text.exit_code == 0, text.output
    assert "injected drops" in text.output and "thrown away (--drop-rate 0.3" in text.output
