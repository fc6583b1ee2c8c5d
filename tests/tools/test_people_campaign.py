"""`shoal campaign --people` (tools/campaign/people.py): fields with crowds crossing the path,
drawn reproducibly inside every check, judged by contact fault, success and time to goal."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from shoal.geometry import safety
from shoal.geometry.safety import Row, mover_row
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
from shoal.world.contacts import least_gaps
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.unicycle import body_centres

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


UNICYCLES = FieldOptions(kinematics="unicycle")


def test_unicycles_among_people_tick_fast_enough_for_the_robots_speed() -> None:
    """crossing's robots made unicycles: l = (ρ − r)/2 = 0.05 m, so at crossing's 20 Hz a point
    moves at most l/dt = 1 m/s, and every field was refused (the reach reckoned at 3 m/s). Made
    for the people campaign's 3 m/s they run 4 ticks for each of crossing's (80 Hz: 4 m/s), the
    convergence tolerance kept in metres; no contact is the robots' fault."""
    crossing = load_scenario("crossing")
    opts = PeopleOptions(count=5)
    field = add_people(crossing, 2, UNICYCLES, opts)
    assert field.unicycle is not None and field.dt == crossing.dt / 4
    assert field.unicycle.lookahead / field.dt > opts.agent_speed
    assert field.control.speed_limit == opts.agent_speed <= field.unicycle.fastest_point(field.dt)
    assert field.tolerance == pytest.approx(crossing.tolerance)
    assert add_people(crossing, 2, FieldOptions(), opts).dt == crossing.dt  # points as they were
    out = run_people_task(PeopleTask(crossing.source, crossing.name, 2, UNICYCLES, opts))
    assert out.error is None and out.dt == field.dt
    assert out.agent_at_fault == 0 and out.other_collisions == 0 and out.success


def test_a_unicycles_contact_with_a_person_is_judged_by_its_bodys_reach() -> None:
    """A unicycle's body lies up to l behind its point: a contact is judged by the body's reach
    about the point's chord (world/contacts.py), which the true body never comes inside; the
    agent's radius alone (a point robot's) lets the body come closer than the judged gap."""
    field = add_people(load_scenario("crossing"), 4, UNICYCLES, PeopleOptions(count=5))
    traj = simulate(field)
    gaps, _ = least_gaps(field, traj)
    assert field.unicycle is not None and traj.headings is not None and traj.movers is not None
    ticks = traj.ticks
    bodies = body_centres(traj.positions[:ticks], traj.headings[:ticks], field.unicycle.lookahead)
    radii = np.asarray([field.obstacles[k].radius for k in field.mover_ids])
    apart = np.linalg.norm(bodies[:, :, None, :] - traj.movers[:ticks, None, :, :], axis=-1)
    body_gaps = apart - radii - field.agent_radius  # the true body's, at the tick's start
    assert (body_gaps >= gaps - 1e-12).all()
    as_points = gaps + field.body_reach - field.agent_radius  # judged with the radius alone
    assert (body_gaps < as_points - 0.01).any()  # the body comes > 1 cm closer than that says


def test_the_cli_runs_unicycles_among_people_and_says_so() -> None:
    args = ["campaign", "--people", "5", "--kinematics", "unicycle", "--fields", "2",
            "--jobs", "1"]  # fmt: skip
    out = CliRunner().invoke(main, [*args, "--json"])
    assert out.exit_code == 0, out.output
    rep = json.loads(out.output.strip().splitlines()[-1])
    assert rep["kinematics"] == "unicycle" and rep["fields"] == 2 and rep["not_drawn"] == 0
    assert rep["agent_at_fault"] == 0 and rep["dt"] == [0.0125]
    text = CliRunner().invoke(main, args).output
    assert "robots                 unicycles, dt 0.0125 s" in text
