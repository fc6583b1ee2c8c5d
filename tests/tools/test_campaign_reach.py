"""`shoal campaign --plant mujoco --safety-layer reach`: every field's reference run goes through
the reach layer; each field's outcome carries the layer's counts, the sets sum them beside the
engine's figures and the time to goal, and a saved field says how to rerun it with the layer.

Two fields of 8 m (a few CPU seconds each in MuJoCo) keep the module well under a minute."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from shoal.bus.types import SafetyLayer
from shoal.tools.campaign.fields import FieldOptions, make_field
from shoal.tools.campaign.hard import hard_field
from shoal.tools.campaign.report import render
from shoal.tools.campaign.runner import Task, run_task
from shoal.tools.cli import main
from shoal.world.loader import load_scenario

pytest.importorskip("mujoco")

OBSTACLES = load_scenario("obstacles")
SHORT = ["--length", "8"]
REACH = FieldOptions(length=8.0, plant="mujoco", layer=SafetyLayer.REACH)


def shoal(*args: str) -> Result:
    result = CliRunner().invoke(main, list(args))
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result


def test_a_reach_campaigns_outcomes_carry_the_layers_counts(tmp_path: Path) -> None:
    lagging, failures = tmp_path / "lagging", tmp_path / "failures"
    result = shoal(
        "campaign", "--fields", "2", *SHORT, "--jobs", "2", "--plant", "mujoco",
        "--safety-layer", "reach", "--json", "--save-lagging", str(lagging),
        "--save-failures", str(failures),
    )  # fmt: skip
    assert result.exit_code in (0, 1), result.output  # 1: a field collided (data, with mass)
    rep = json.loads(result.stdout)
    assert (rep["plant"], rep["safety_layer"]) == ("mujoco", "reach")
    inside = rep["sets"]["inside"]
    assert inside["fields"] == 2 and inside["safety_layer"] == "reach"
    # each field's outcome, as a worker makes it: the reach layer's counts, which the set sums
    outcomes = [run_task(Task(OBSTACLES.source, "obstacles", k, "inside", REACH)) for k in (0, 1)]
    for o in outcomes:
        assert o.error is None and o.safety_layer == "reach"
        assert o.reach_brakes is not None and o.reach_slowed is not None
        assert o.reach_largest_margin is not None and o.reach_largest_margin > 0
    assert inside["reach_brakes"] == sum(o.reach_brakes or 0 for o in outcomes)
    assert inside["reach_slowed"] == sum(o.reach_slowed or 0 for o in outcomes)
    assert inside["reach_largest_margin"] == max(o.reach_largest_margin or 0 for o in outcomes)
    arrived = [o.arrival_time for o in outcomes if o.arrived and o.arrival_time is not None]
    assert inside["arrival_time_max"] == max(arrived, default=None)
    assert "engine_contacts" in inside and "tracking_error_p99" in inside  # beside the engine's
    # every field kept says how to rerun it through the layer
    saved = [*lagging.glob("*.yaml"), *failures.glob("*.yaml")]
    assert len(saved) == inside["collided"] + len(rep["lagging"])
    for path in saved:
        assert "# Reproduce: shoal simulate --plant mujoco --safety-layer reach THIS_FILE" in (
            path.read_text()
        )
    for row in rep["failures"]:
        assert row["rerun"] == "simulate --plant mujoco --safety-layer reach"
        assert row["reach_slowed"] is not None
    # the text report: the layer's price table, its columns and the note
    text = render(rep)
    row = next(line for line in text.splitlines() if line.startswith("inside       reach"))
    assert f" {inside['reach_slowed']} " in row and f"{inside['reach_largest_margin']:.3f}" in row
    assert "largest margin    reach: the most any certified step needed, m" in text
    assert "every field through the reach layer" in text
    assert "robots with mass: mujoco (holonomic)" in text


def test_a_referee_campaign_on_mass_shows_the_time_to_goal_without_reach_counts() -> None:
    result = shoal("campaign", "--fields", "1", *SHORT, "--jobs", "1", "--plant", "mujoco",
                   "--json")  # fmt: skip
    rep = json.loads(result.stdout)
    inside = rep["sets"]["inside"]
    assert "safety_layer" not in rep and inside["safety_layer"] == "referee"
    assert inside["reach_brakes"] is None and inside["reach_largest_margin"] is None
    assert "arrival_time_p50" in inside
    text = render(rep)
    row = next(line for line in text.splitlines() if line.startswith("inside       ref"))
    assert row.split()[2:6] == ["—", "—", "—", "—"]  # brakes, fields, slowed, largest margin
    assert "robots with mass: mujoco (holonomic)" in text
    assert "reach layer" not in text


def test_the_fields_say_the_layer_in_their_reproduce_line() -> None:
    field = make_field(OBSTACLES, 3, "inside", REACH)
    assert "# Reproduce: shoal simulate --plant mujoco --safety-layer reach THIS_FILE" in (
        field.source
    )
    plain = make_field(OBSTACLES, 3, "inside", FieldOptions(length=8.0, plant="mujoco"))
    assert "--safety-layer" not in plain.source
    assert field.source.split("\n", 3)[3] == plain.source.split("\n", 3)[3]  # the same field
    hard = hard_field(5, 2, layer=SafetyLayer.REACH)
    assert "# Reproduce: shoal simulate --safety-layer reach THIS_FILE" in hard.source


@pytest.mark.parametrize(
    ("options", "reason"),
    [
        (("--kinematics", "unicycle"), "unicycles"),
        (("--safety", "paper"), "safety: paper"),
        (("--swarm", "1"), "not with --swarm"),
    ],
)
def test_what_the_layer_refuses_is_refused_before_any_field_runs(
    options: tuple[str, str], reason: str
) -> None:
    result = shoal("campaign", "--fields", "1", *SHORT, "--safety-layer", "reach", *options)
    assert result.exit_code == 2, result.output
    assert reason in result.stderr and "Traceback" not in result.output
    assert "fields around" not in result.output  # nothing ran
