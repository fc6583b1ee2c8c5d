"""`shoal campaign --people` (tools/campaign/people.py): fields with crowds crossing the path,
drawn reproducibly inside every check, judged by contact fault, success and time to goal."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from shoal.bus import safety
from shoal.bus.safety import Row, mover_row
from shoal.tools.campaign.fields import FieldOptions
from shoal.tools.campaign.people import (
    PeopleOptions,
    PeopleTask,
    add_people,
    run_people_task,
    time_to_goal,
    without_people,
)
from shoal.tools.cli import main
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario, parse_scenario

BASE = load_scenario("obstacles")


@pytest.mark.parametrize("model", ["reactive", "blind"])
def test_a_crowd_is_drawn_reproducibly_inside_every_check_and_meets_the_formation(
    model: str,
) -> None:
    opts = PeopleOptions(count=5, speed=1.34, model=model)
    field = add_people(BASE, 7, FieldOptions(), opts)
    again = add_people(BASE, 7, FieldOptions(), opts)
    assert field.source == again.source
    assert parse_scenario(field.source).source == field.source  # it reloads as it is
    assert len(field.mover_ids) == 5
    kinds = {field.obstacles[k].motion.__class__.__name__ for k in field.mover_ids}
    assert kinds == ({"Person"} if model == "reactive" else {"Drift"})
    assert field.control.speed_limit == opts.agent_speed
    traj = simulate(field)
    assert traj.movers is not None
    # People and leader meet: some person comes within 3 m of the leader during the run.
    gaps = np.linalg.norm(traj.movers[:-1] - traj.positions[:-1, :1], axis=-1)
    assert gaps.min() < 3.0
    calm = without_people(field)
    assert calm.mover_ids == () and len(calm.standing_ids) == len(field.standing_ids)


def test_one_field_is_judged_with_its_static_twin() -> None:
    task = PeopleTask(BASE.source, BASE.name, 3, FieldOptions(), PeopleOptions(count=4))
    out = run_people_task(task)
    assert out.error is None
    assert out.agent_at_fault == 0 and out.other_collisions == 0
    assert out.success and out.static_success
    assert out.time_to_goal is not None and out.static_time is not None
    assert out.time_to_goal >= out.static_time * 0.8
    field = add_people(BASE, 3, FieldOptions(), PeopleOptions(count=4))
    assert out.time_to_goal == time_to_goal(field, simulate(field))


def test_the_cli_reports_contacts_by_fault_and_fails_on_an_agents_fault(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Blind walkers at 1.75 m/s over a few fields: the report counts contacts by fault and
    exits 0 with none the agents' fault; with a filter blind to people, agents walk into
    them and the campaign exits 1."""
    args = ["campaign", "--people", "5", "--people-speed", "1.75", "--people-model", "blind",
            "--fields", "6", "--jobs", "1", "--json"]  # fmt: skip
    good = CliRunner().invoke(main, args)
    assert good.exit_code == 0, good.output
    rep = json.loads(good.output.strip().splitlines()[-1])
    assert rep["fields"] == 6 and rep["agent_at_fault"] == 0
    assert all(c["fault"] == "obstacle" for c in rep["contacts"])

    def blind(position: tuple[float, ...], m: object, margin: float, dt: float) -> Row:
        row = mover_row(position, m, margin, dt)  # type: ignore[arg-type]
        return Row(row.normal, -1e9, True, True)  # met by any velocity: no row at all

    monkeypatch.setattr(safety, "mover_row", blind)
    bad = CliRunner().invoke(main, args)
    assert bad.exit_code == 1
    rep = json.loads(bad.output.strip().splitlines()[0])
    assert rep["agent_at_fault"] > 0


def test_people_options_are_checked() -> None:
    out = CliRunner().invoke(main, ["campaign", "--people", "0", "--fields", "1"])
    assert out.exit_code == 2 and "--people" in out.output
    out = CliRunner().invoke(main, ["campaign", "--people", "2", "--people-model", "x"])
    assert out.exit_code == 2 and "--people-model" in out.output
    out = CliRunner().invoke(main, ["campaign", "--people", "2", "--safety", "paper"])
    assert out.exit_code == 2 and "needs the safety filter" in out.output
