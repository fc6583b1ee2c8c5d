"""The safety filter across processes: a lockstep swarm on fields where the filter acts equals
the reference bit for bit (the world's safety layer changing nothing), and a realtime swarm,
whose commands are applied from later positions than they were computed at, keeps every guard
and every separation anyway, because the world filters each command again with fresh positions.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import json_of, run_cli

from shoal.tools.campaign.fields import FieldOptions, make_field
from shoal.tools.campaign.swarms import render_swarms
from shoal.tools.log.reader import read_trajectory
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario, parse_scenario

pytestmark = pytest.mark.integration

OPTIONS = FieldOptions(length=10.0, tail=3.0)  # 13 s of simulated time a field


def _field(seed: int, tmp_path: Path) -> Path:
    field = make_field(load_scenario("obstacles"), seed, options=OPTIONS)
    path = tmp_path / f"{field.name}.yaml"
    path.write_text(field.source, encoding="utf-8")
    return path


@pytest.mark.parametrize("seed", [1, 10])
def test_a_filtered_lockstep_swarm_equals_the_reference_bit_for_bit(
    seed: int, tmp_path: Path
) -> None:
    path = _field(seed, tmp_path)
    scn = parse_scenario(path.read_text(encoding="utf-8"))
    ref = simulate(scn)
    assert ref.filtered.sum() > 50  # the filter really acts on this field (132 and 379 ticks)
    out = tmp_path / "run.mcap"
    proc = run_cli(["run", str(path), "--json", "--no-foxglove", "--out", str(out)])
    assert proc.returncode == 0
    got = read_trajectory(out, dt=scn.dt)
    assert got.equals(ref)
    summary = json_of(proc)
    assert summary["actuator_corrections"] == 0  # every command was already feasible
    assert summary["collisions"] == 0
    assert summary["filter_activity"] == pytest.approx(float(ref.filtered.mean()))


def test_a_realtime_swarm_keeps_every_guard_and_separation(tmp_path: Path) -> None:
    path = _field(6, tmp_path)
    scn = parse_scenario(path.read_text(encoding="utf-8"))
    proc = run_cli(["run", str(path), "--clock", "realtime", "--speed", "1", "--json",
                    "--no-foxglove", "--out", str(tmp_path / "rt.mcap")])  # fmt: skip
    assert proc.returncode == 0
    got = json_of(proc)
    assert got["collisions"] == 0
    rho = scn.control.safety_margin
    assert got["min_clearance"] >= rho - 1e-9  # exactly the theorem's guard, not "about"
    assert got["min_interagent_distance"] >= scn.separation - 1e-9


def test_messages_later_than_the_watchdog_allows_only_hold_robots_still(tmp_path: Path) -> None:
    """Each robot's own layer, the delay bound exceeded on purpose: every agent's states and
    commands 50 ± 30 ms late against a watchdog that applies nothing older than 5 ticks (50 ms
    at dt 0.01 s, speed 1), the robots' own radio as late, 5 % lost, each robot's estimate off
    by up to 0.05 m, no referee. Many commands arrive too late to be applied, so robots are held
    (``stale_holds``) and stand for snapshots (``layer_standing``), but the guard and the
    separation still hold exactly: the theorem (docs/safety.md, Without a referee) assumes no
    delay bound, the bound only decides how long robots wait."""
    opts = FieldOptions(length=8.0, tail=1.0, speed_limit=4.0, position_error=0.05)
    field = make_field(load_scenario("obstacles"), 6, options=opts)
    path = tmp_path / f"{field.name}.yaml"
    path.write_text(field.source, encoding="utf-8")
    scn = parse_scenario(field.source)
    proc = run_cli(["run", str(path), "--clock", "realtime", "--speed", "1", "--json",
                    "--delay-ms", "50", "--jitter-ms", "30", "--drop-rate", "0.05",
                    "--no-foxglove", "--out", str(tmp_path / "late.mcap")])  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    got = json_of(proc)
    assert got["safety_layer"] == "onboard"
    assert got["stale_holds"] > 0 and got["layer_standing"] > 0
    assert got["collisions"] == 0
    assert got["min_clearance"] >= scn.control.safety_margin - 1e-9
    assert got["min_interagent_distance"] >= scn.separation - 1e-9
    print(f"\nlate beyond the watchdog: {got['stale_holds']} stale holds, "
          f"{got['layer_standing']} robot-ticks standing, clearance "
          f"{got['min_clearance']:.7f} m, separation {got['min_interagent_distance']:.4f} m, "
          f"arrived {got['arrived']}")  # fmt: skip


def test_campaign_swarm_runs_fields_as_processes_and_checks_them() -> None:
    proc = run_cli(["campaign", "--swarm", "1", "--swarm-clock", "lockstep", "--length", "8",
                    "--json"])  # fmt: skip
    assert proc.returncode == 0
    rep = json_of(proc)
    assert rep["fields"] == 1 and rep["clock"] == "lockstep"
    assert rep["inexact"] == 0 and rep["collided"] == 0 and rep["actuator_corrections"] == 0
    (row,) = rep["rows"]
    assert row["exact"] is True and row["name"] == "obstacles-inside-0"
    assert row["min_clearance"] >= row["rho"] - 1e-9
    # time to goal: the one field's own, when it arrived
    assert rep["arrival_time_p50"] == (row["arrival_time"] if row["arrived"] else None)
    assert row["arrival_time"] is None or row["arrival_time"] > 0


def test_a_swarm_campaign_without_referee_counts_what_it_would_change() -> None:
    """--swarm-safety-layer none: in lockstep the referee has nothing to change (0 counted) and
    the run is still the reference's, bit for bit; the text says there was no referee. One
    swarm: the text is what the command prints for this very report without --json
    (tools/commands/campaign.py ``_swarms``: ``render_swarms(rep)``, the exit status alike);
    running the swarm a second time for it cost CI 10 s."""
    proc = run_cli(["campaign", "--swarm", "1", "--swarm-clock", "lockstep", "--length", "8",
                    "--swarm-safety-layer", "none", "--json"])  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    rep = json_of(proc)
    assert rep["safety_layer"] == "none" and rep["referee_would_correct"] == 0
    assert rep["inexact"] == 0 and rep["collided"] == 0 and rep["arrived"] in (0, 1)
    (row,) = rep["rows"]
    assert row["exact"] is True and row["referee_would_correct"] == 0
    assert "no safety layer (no referee: it would have changed 0" in render_swarms(rep)


def test_campaign_swarm_with_people_equals_the_reference_bit_for_bit() -> None:
    """Two people fields (crossing's base, five reactive people each) as distributed lockstep
    runs: every tick, people included, equals the reference simulator."""
    proc = run_cli(["campaign", "--swarm", "2", "--swarm-clock", "lockstep", "--people", "5",
                    "--json"])  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    rep = json_of(proc)
    assert rep["fields"] == 2 and rep["inexact"] == 0 and rep["agent_at_fault"] == 0
    for row in rep["rows"]:
        assert row["exact"] is True and row["name"].startswith("crossing-inside-")
        assert row["min_mover_clearance"] is not None
