"""`--safety-layer reach` on the command line: `shoal simulate` runs the reference through the
reach layer and prints its counts, refuses what the layer refuses with a message and no
traceback, and `shoal verify` re-runs a reach run's log with the layer its summary names.

Short runs (8 s of obstacles on holonomic bases: ~2 CPU s each) keep the fast tests fast; the
real distributed run is an integration test."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner, Result
from conftest import shortened
from physics_cases import CRASH

from shoal.bus.types import SafetyLayer
from shoal.tools.cli import main
from shoal.tools.commands.report import json_safe, render_summary
from shoal.tools.log.reader import read_ticks
from shoal.tools.simulator import reference, run, simulate
from shoal.tools.verify import recorded_layer
from shoal.world.loader import load_scenario
from shoal.world.metrics import summarize

REACH_KEYS = ("reach_brakes", "reach_slowed", "reach_largest_margin")


def shoal(*args: str) -> Result:
    """``shoal ARGS`` in this process; an exception other than click's exit is re-raised (a
    traceback a person would have seen)."""
    result = CliRunner().invoke(main, list(args))
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


@pytest.fixture
def short(tmp_path: Path) -> Path:
    """obstacles cut to 8 s: its first obstacle met, 800 ticks."""
    pytest.importorskip("mujoco")
    return shortened(tmp_path, "obstacles", 8.0)


def test_simulate_through_the_reach_layer_prints_its_counts(short: Path) -> None:
    args = ("simulate", str(short), "--plant", "mujoco", "--dynamics", "holonomic")
    result = shoal(*args, "--safety-layer", "reach", "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["safety_layer"] == "reach"
    assert isinstance(summary["reach_brakes"], int) and isinstance(summary["reach_slowed"], int)
    assert summary["reach_largest_margin"] > 0  # bases with mass need room to stop
    # exactly the reference's, through the layer asked for
    scn = load_scenario(str(short))
    traj, judged = reference(scn, plant="mujoco", dynamics="holonomic", layer=SafetyLayer.REACH)
    assert summary == json_safe({**summarize(scn, traj).as_dict(), **judged})

    text = shoal(*args, "--safety-layer", "reach")
    assert text.exit_code == 0, text.output
    row = next(line for line in text.stdout.splitlines() if line.startswith("safety layer"))
    assert f"{summary['reach_brakes']} robot-ticks told to stop" in row
    assert f"{summary['reach_slowed']} agent-ticks slowed" in row
    assert f"largest margin {summary['reach_largest_margin']:.3f} m" in row


def test_simulate_with_the_referee_has_no_reach_counts(tmp_path: Path) -> None:
    short = shortened(tmp_path, "obstacles", 2.0)
    result = shoal("simulate", str(short), "--json", "--safety-layer", "referee")
    assert result.exit_code == 0, result.output
    assert not any(key in json.loads(result.stdout) for key in REACH_KEYS)
    assert "told to stop" not in shoal("simulate", str(short)).stdout


def test_unicycles_are_refused_by_name_without_a_traceback() -> None:
    result = shoal("simulate", "robotarium", "--safety-layer", "reach")
    assert result.exit_code == 2, result.output
    assert "--safety-layer reach cannot run robotarium" in result.stderr
    assert "unicycles" in result.stderr
    assert "Traceback" not in result.output


@pytest.mark.parametrize("command", [("run",), ("world", "--run", "r1")])
def test_run_and_world_refuse_unicycles_before_anything_starts(command: tuple[str, ...]) -> None:
    """``shoal run`` and ``shoal world`` say why before a router or an agent is started."""
    result = shoal(*command, "robotarium", "--safety-layer", "reach")
    assert result.exit_code == 2, result.output
    assert "--safety-layer reach cannot run robotarium" in result.stderr
    assert "unicycles" in result.stderr


def test_safety_paper_is_refused_by_name(tmp_path: Path) -> None:
    crash = tmp_path / "crash.yaml"
    crash.write_text(CRASH)
    result = shoal("simulate", str(crash), "--safety-layer", "reach")
    assert result.exit_code == 2, result.output
    assert "cannot run crash" in result.stderr and "safety: paper" in result.stderr


def test_the_summary_shows_the_reach_row_only_for_the_reach_layer(tmp_path: Path) -> None:
    scn = load_scenario(str(shortened(tmp_path, "sinusoid", 1.0)))
    base: dict[str, Any] = json_safe(summarize(scn, simulate(scn)).as_dict())
    reach = {**base, "safety_layer": "reach", "reach_brakes": 3, "reach_slowed": 41,
             "reach_largest_margin": 0.25}  # fmt: skip
    assert "safety layer              reach: " in render_summary(reach)
    shown = render_summary(reach)
    assert "3 robot-ticks told to stop" in shown and "41 agent-ticks slowed" in shown
    assert "largest margin 0.250 m" in shown
    assert "told to stop" not in render_summary({**base, "safety_layer": "referee"})
    engine = {**reach, "plant": "mujoco"}
    assert "the reach layer's theorem for robots with mass" in render_summary(engine)
    assert "robots that move as commanded" in render_summary({**engine, "safety_layer": "referee"})


def test_verify_takes_the_layer_from_the_log() -> None:
    assert recorded_layer({"summary": {"safety_layer": "reach"}}) == SafetyLayer.REACH
    assert recorded_layer({"scenario": {"safety_layer": "reach"}}) == SafetyLayer.REACH
    for other in ("referee", "onboard", "none", None):
        assert recorded_layer({"summary": {"safety_layer": other}}) == SafetyLayer.REFEREE
    assert recorded_layer({}) == SafetyLayer.REFEREE  # a log cut short: no summary


@pytest.mark.integration
def test_a_reach_run_verifies_against_the_reach_reference(tmp_path: Path) -> None:
    """A distributed lockstep run through the reach layer equals the reference with the same
    layer bit for bit; re-run with the referee, it would differ from tick 0."""
    pytest.importorskip("mujoco")
    short, out = shortened(tmp_path, "obstacles", 3.0), tmp_path / "run.mcap"
    ran = shoal("run", str(short), "--plant", "mujoco", "--dynamics", "holonomic",
                "--safety-layer", "reach", "--json", "--out", str(out))  # fmt: skip
    assert ran.exit_code == 0, ran.output
    checked = shoal("verify", str(out))
    assert checked.exit_code == 0, checked.output
    assert "300 of 300 recorded ticks match the reference simulator (with the reach layer)" in (
        checked.stdout
    )
    first = read_ticks(out)[0]
    referee = next(run(load_scenario(str(short)), "mujoco", "holonomic", SafetyLayer.REFEREE))
    assert referee.positions != first.positions or referee.velocities != first.velocities
