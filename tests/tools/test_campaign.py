"""`shoal campaign` and its field generator (tools/campaign/fields.py): determinism, inside fields
pass every load-time check, each outside field breaks exactly what it names, and a small campaign
through the CLI whose saved failures replay exactly."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import signal
import subprocess
import warnings
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from conftest import PYTHON

from shoal.tools.campaign.fields import (
    BREACHES,
    REFUSED,
    FieldError,
    FieldOptions,
    breaches,
    load_field,
    make_field,
    needed_contraction,
    unicycle_for,
    unicycle_ticks,
)
from shoal.tools.campaign.hard import hard_field
from shoal.tools.campaign.report import render, report
from shoal.tools.campaign.runner import Outcome, judge
from shoal.tools.cli import main
from shoal.world.assumptions import check_assumptions
from shoal.world.errors import AssumptionError, BetaWarning, DetourWarning, ScenarioError
from shoal.world.loader import load_scenario, parse_scenario

OBSTACLES = load_scenario("obstacles")
NUMBERED = {"A2": 2, "A3": 3, "A4": 4}


@pytest.mark.parametrize("mode", ["inside", *BREACHES])
def test_a_field_is_a_function_of_its_seed(mode: str) -> None:
    first = make_field(OBSTACLES, 7, mode)
    assert make_field(OBSTACLES, 7, mode).source == first.source
    assert make_field(OBSTACLES, 8, mode).source != first.source
    assert first.name == f"obstacles-{mode}-7"


@pytest.mark.parametrize("base", ["obstacles", "default", "sinusoid", "passage"])
def test_inside_fields_pass_every_load_time_check(base: str) -> None:
    scenario = load_scenario(base)
    for seed in range(15):
        field = make_field(scenario, seed)
        assert 2 <= len(field.obstacles) <= 5
        assert breaches(field) == frozenset()
        check_assumptions(field)  # raises on a broken assumption; warnings are errors here
        again = parse_scenario(field.source)  # the YAML is the field
        assert again.obstacles == field.obstacles
        assert (again.initial_positions == field.initial_positions).all()


@pytest.mark.parametrize("mode", sorted(m for m in BREACHES if BREACHES[m].static))
def test_each_outside_field_breaks_exactly_what_it_names(mode: str) -> None:
    for seed in range(8):
        field = make_field(OBSTACLES, seed, mode)
        assert breaches(field) == {mode}
        if mode == "A4":  # with the filter the leader goes round; Algorithm 2 alone: refused
            with pytest.warns(DetourWarning, match="the leader will go round it"):
                parse_scenario(field.source)
            paper = make_field(OBSTACLES, seed, mode, FieldOptions(safety="paper"))
            with pytest.raises(AssumptionError) as refused_a4:
                parse_scenario(paper.source)
            assert refused_a4.value.assumption == 4
        elif mode in REFUSED:  # the loader refuses it, naming the assumption
            with pytest.raises(ScenarioError) as refused:
                parse_scenario(field.source)
            if mode in NUMBERED:
                assert isinstance(refused.value, AssumptionError)
                assert refused.value.assumption == NUMBERED[mode]
            else:
                assert refused.value.field == "control.trigger_radius"
            assert load_field(field.source).obstacles == field.obstacles
        else:
            with pytest.warns(BetaWarning):
                parse_scenario(field.source)


def test_gap_fields_need_more_than_sigma_max_and_break_nothing_checked() -> None:
    for seed in range(8):
        field = make_field(OBSTACLES, seed, "gap")
        assert breaches(field) == frozenset()
        assert needed_contraction(field, 0, 1) > field.control.sigma_max


def test_a2_fields_cut_an_agent_off_only_through_one_missing_edge() -> None:
    for seed in range(4):
        field = make_field(OBSTACLES, seed, "A2")
        assert len(field.edges) == len(OBSTACLES.edges) - 1
        assert set(field.edges) < set(OBSTACLES.edges)


def test_an_impossible_field_is_a_clear_error() -> None:
    with pytest.raises(FieldError, match=r"no place for obstacle .* in 5 tries"):
        make_field(OBSTACLES, 0, options=FieldOptions(count=(40, 40), tries=5))
    with pytest.raises(FieldError, match="ends before obstacles may start"):
        make_field(OBSTACLES, 0, options=FieldOptions(length=3.0))
    with pytest.raises(ValueError, match="unknown field mode"):
        make_field(OBSTACLES, 0, "A9")


def test_inside_fields_with_several_obstacles_never_collide_with_the_filter() -> None:
    for seed in range(3):
        outcome = judge(make_field(OBSTACLES, seed))
        assert not outcome.collided
        assert outcome.min_clearance >= OBSTACLES.control.safety_margin - 1e-9
        assert outcome.min_interagent_distance >= 2 * OBSTACLES.control.safety_margin - 1e-9
        assert outcome.arrived and outcome.not_arrived is None and outcome.arrival_time


def test_the_same_field_collides_with_algorithm_2_alone() -> None:
    """The finding the filter answers (docs/campaign.md): field 0 collides unfiltered."""
    field = make_field(OBSTACLES, 0, options=FieldOptions(safety="paper"))
    assert field.control.safety == "paper"
    assert judge(field).collided


# --jobs 2 where a test is about the fields, not about where they run: a worker per core halves
# the wall time on CI's two cores, and the outcomes come back in task order either way
# (tools/campaign/runner.py). The in-process path, --jobs 1, stays with the up-front test's
# hard campaign, the crossing unicycles here and tests/tools/test_people_campaign.py.
def _campaign(*args: str) -> tuple[int, dict[str, Any]]:
    result = CliRunner().invoke(main, ["campaign", "--json", *args])
    assert result.exit_code in (0, 1), result.output
    return result.exit_code, json.loads(result.stdout)


def test_a_small_campaign_is_safe_inside_and_its_failures_replay(tmp_path: Path) -> None:
    saved = tmp_path / "failures"
    code, rep = _campaign(
        "--fields", "10", "--obstacles", "1", "--outside", "--outside-fields", "1", "--jobs", "2",
        "--save-failures", str(saved), "--safety", "both", "--save-lagging", str(tmp_path / "lag"),
    )  # fmt: skip
    assert code == 0, rep["failures"]
    inside = rep["sets"]["inside"]
    assert inside["fields"] == 10 and inside["collided"] == 0
    assert inside["min_clearance"]["min"] >= 0.2 - 1e-9  # ρ: the filter's guard
    assert inside["converged_within_bound"] == inside["converged"] == 10
    assert inside["arrived"] == 10 and inside["arrival_rate"] == 1.0 and not inside["not_arrived"]
    slack = 1900 * 4e-12  # contact_slack of a 1,900-tick field
    assert inside["guard_margin"] >= -slack and inside["separation_margin"] >= -slack
    paper = {f"{m}/paper" for m in ("inside", *BREACHES)}
    assert set(rep["sets"]) == {"inside", *BREACHES} | paper
    assert rep["fields"] == 2 * (10 + len(BREACHES)) and not rep["errors"]
    for name, s in rep["sets"].items():
        assert s["fields"] == (10 if name.startswith("inside") else 1)
        if s["safety"] == "filter":  # every set, even outside the paper's assumptions
            assert s["collided"] == 0, name
            assert s["min_interagent_distance"]["min"] >= 0.4 - 1e-9
        assert max(s["obstacle_collided"], s["agent_collided"]) <= s["collided"]
        assert s["collided"] <= s["obstacle_collided"] + s["agent_collided"]
        assert s["converged_within_bound"] <= s["converged"] <= s["fields"]
        clr = s["min_clearance"]
        assert clr["min"] <= clr["p01"] <= clr["p05"] <= clr["p50"]
    assert rep["sets"]["A4/paper"]["collided"] == 1  # the leader drives through the obstacle
    assert rep["sets"]["A4"]["leader_reached"] == 1  # filtered, it goes round instead
    for g in rep["lagging"]:  # saved as the field it is
        assert Path(g["file"]).read_text().startswith("#") and g["file"].endswith(".yaml")
    failures = rep["failures"]
    assert sum(s["collided"] for s in rep["sets"].values()) == len(failures)
    assert any(f["rerun"] == "simulate" for f in failures)  # one the loader accepts
    for f in failures:
        path = Path(f["file"])
        assert path.parent == saved
        args = (
            ["simulate", str(path)]
            if f["rerun"] == "simulate"
            else ["campaign", "--rerun", str(path)]
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BetaWarning)
            result = CliRunner().invoke(main, [*args, "--json"])
        assert result.exit_code == 0, result.output
        again = json.loads(result.stdout)
        assert again["min_clearance"] == f["min_clearance"]  # bit for bit
        assert again["collisions"] == f["obstacle_collisions"] + f["agent_collisions"]


def test_rerun_names_what_a_saved_field_breaks(tmp_path: Path) -> None:
    path = tmp_path / "a4.yaml"
    path.write_text(make_field(OBSTACLES, 1, "A4", FieldOptions(safety="paper")).source)
    result = CliRunner().invoke(main, ["campaign", "--rerun", str(path)])
    assert result.exit_code == 0, result.output
    assert "breaks                    A4" in result.output
    assert "agent–obstacle" in result.output
    refused = CliRunner().invoke(main, ["simulate", str(path)])
    assert refused.exit_code == 1 and "Assumption 4 violated" in refused.output


def test_with_the_filter_an_a4_field_runs_with_a_warning_and_the_leader_goes_round(
    tmp_path: Path,
) -> None:
    path = tmp_path / "a4.yaml"
    path.write_text(make_field(OBSTACLES, 1, "A4").source)
    result = CliRunner().invoke(main, ["simulate", str(path), "--json"])
    assert result.exit_code == 0, result.output
    assert "the leader will go round it" in result.stderr
    got = json.loads(result.stdout)
    assert got["collisions"] == 0 and got["leader_shortfall"] <= got["tolerance"]


def test_bad_obstacle_count_is_a_usage_error() -> None:
    result = CliRunner().invoke(main, ["campaign", "--obstacles", "five"])
    assert result.exit_code == 2
    assert "expected N or LOW-HIGH" in result.output


def test_the_campaign_says_up_front_how_many_runs_its_options_make() -> None:
    """--fields N runs N fields; --outside adds the sets that break an assumption, and the
    banner says the total before the first field runs, and every column is explained."""
    alone = CliRunner().invoke(main, ["campaign", "--fields", "3", "--obstacles", "1"])
    assert alone.exit_code == 0, alone.output
    assert alone.stderr.startswith(
        "3 runs: 3 fields inside the assumptions (--outside: also fields that break one"
    )
    assert "3 fields on" in alone.stdout
    legend = alone.stdout.split("columns:\n")[1]
    named = [line.split("  ")[1] for line in legend.splitlines() if line.startswith("  ")]
    for header in ("σ > 1", "A3 by σ", "A2 in run", "leader at goal", "sep. margin", "p05"):
        assert any(header in n for n in named), header  # every column is explained
    more = CliRunner().invoke(
        main,
        ["campaign", "--fields", "1", "--obstacles", "1", "--outside", "--outside-fields", "1"],
    )
    assert more.exit_code == 0, more.output
    runs = 1 + len(BREACHES)
    assert more.stderr.startswith(
        f"{runs} runs: 1 fields inside the assumptions and 1 for each of the {len(BREACHES)} "
        "broken ones\n"
    )
    hard = CliRunner().invoke(main, ["campaign", "--kind", "hard", "--fields", "3", "--jobs", "1"])
    assert hard.stderr.startswith("3 runs: 2 hard fields in 2-D and 1 in 3-D")


def test_ctrl_c_stops_a_campaign_at_once_and_leaves_no_worker() -> None:
    """Interrupted, a campaign used to run every queued field first (6 minutes for 200)."""
    proc = subprocess.Popen(
        [*PYTHON, "campaign", "--fields", "10000", "--no-outside", "--jobs", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),  # as in a terminal
    )  # fmt: skip
    assert proc.stderr is not None
    try:
        assert "10000 runs" in proc.stderr.readline()  # under way: the workers are starting
        os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C sends: the whole foreground group
        _out, err = proc.communicate(timeout=60)  # 10,000 fields would take hours
        try:
            os.killpg(proc.pid, 0)
            left = True  # a worker of the group is still running
        except ProcessLookupError:
            left = False
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)  # a failing run must not go on for hours
        proc.wait()
    assert proc.returncode == 1 and "Aborted!" in err
    assert not left


def test_the_report_lists_every_safe_field_that_stalled_or_did_not_settle() -> None:
    ok = Outcome(
        "inside", 0, "f-0", 2, 0, 0, 0.3, 0.5, 1.0, 2.0, 0.05, 0.2, 1.0, False, 1, 0, 1.0,
        source="yaml", arrival_time=12.0,
    )  # fmt: skip
    stalled = dataclasses.replace(ok, seed=1, stalls=2, longest_stall=1.5)
    unsettled = dataclasses.replace(ok, seed=2, final_formation_error=0.5)
    short = dataclasses.replace(ok, seed=3, leader_reached=False)
    crashed = dataclasses.replace(unsettled, seed=4, obstacle_collisions=1)  # a failure instead
    trapped = dataclasses.replace(
        ok, seed=5, arrived=False, not_arrived="leader trapped", leader_shortfall=21.6,
        leader_reached=False, arrival_time=None,
    )  # fmt: skip
    stuck = dataclasses.replace(
        ok, seed=6, arrived=False, not_arrived="deadlock", slot_distance=2.41, arrival_time=None
    )
    circling = dataclasses.replace(ok, seed=7, livelocks=1, longest_livelock=14.5)
    rep = report(
        [ok, stalled, unsettled, short, crashed, trapped, stuck, circling], wall=1.0, jobs=1
    )
    assert [g["seed"] for g in rep["lagging"]] == [1, 2, 3, 5, 6, 7]
    assert [f["seed"] for f in rep["failures"]] == [4]
    assert rep["lagging"][0]["longest_stall"] == 1.5 and rep["lagging"][0]["settled"]
    assert not rep["lagging"][1]["settled"] and not rep["lagging"][2]["leader_reached"]
    assert rep["lagging"][3]["not_arrived"] == "leader trapped"
    inside = rep["sets"]["inside"]
    assert inside["arrived"] == 6 and inside["arrival_rate"] == 6 / 8
    assert inside["not_arrived"] == {"leader trapped": 1, "deadlock": 1}
    assert inside["livelocked_fields"] == 1 and inside["longest_livelock"] == 14.5
    text = render(rep)
    assert "6 safe fields to look at" in text
    assert "seed      1: 2 stalls, longest 1.50 s" in text
    assert "seed      2: not settled (error 0.500 m)" in text
    assert "seed      3: leader short of its goal" in text
    assert "seed      5: not arrived: leader trapped (leader 21.60 m short)" in text
    assert "seed      6: not arrived: deadlock (a follower 2.41 m off its slot)" in text
    assert "seed      7: 1 livelocks, longest 14.50 s" in text
    assert "6/8 (75.0 %)" in text


def test_a_hard_campaign_runs_the_generators_fields_in_2d_and_3d(tmp_path: Path) -> None:
    """--kind hard: --fields of tools/campaign/hard.py's fields, half in each dimension, their
    own sets with an arrival rate, and a lagging one saved runs as it ran."""
    code, rep = _campaign(
        "--kind", "hard", "--fields", "4", "--jobs", "2", "--save-lagging", str(tmp_path)
    )  # fmt: skip
    assert code == 0, rep["failures"]
    assert set(rep["sets"]) == {"hard/2d", "hard/3d"}
    for s in rep["sets"].values():
        assert s["fields"] == 2 and s["collided"] == 0
        assert 0 <= s["arrived"] <= 2 and s["arrival_rate"] == s["arrived"] / 2
    assert {g["set"] for g in rep["lagging"]} <= {"hard/2d", "hard/3d"}


def test_a_hard_campaign_is_refused_with_options_it_cannot_honour() -> None:
    result = CliRunner().invoke(main, ["campaign", "--kind", "hard", "--safety", "paper"])
    assert result.exit_code == 2 and "--kind hard" in result.output


def test_a_campaign_with_the_boundary_layer_says_so_with_its_figures() -> None:
    """--boundary-layer K runs every field with φ = K·β·dt; the report carries K and the text
    says it is not the paper's law."""
    args = [
        "--kind",
        "hard",
        "--fields",
        "2",
        "--seed",
        "73",
        "--jobs",
        "2",
        "--boundary-layer",
        "2",
    ]
    code, rep = _campaign(*args)
    assert code == 0 and rep["boundary_layer"] == 2.0
    text = CliRunner().invoke(main, ["campaign", *args]).output
    assert "boundary layer φ = 2·β·dt" in text
    assert rep["sets"]["hard/2d"]["arrived"] == 1  # field 73 arrives with it (test_hard_fields)


def test_kinematics_unicycle_turns_the_fields_into_unicycles_facing_anywhere() -> None:
    """--kinematics unicycle: the base's formation as unicycles with figures derived from it
    (unicycle_for), headings drawn per field; every field still admissible, none collides (the
    body judged by its reach about the point's chord), and the report says so."""
    base = load_scenario("obstacles")
    opts = FieldOptions(kinematics="unicycle")
    fields = [make_field(base, seed, "inside", opts) for seed in range(3)]
    robot = unicycle_for(base, base.control.speed_limit)  # obstacles carries 4 m/s
    assert all(f.unicycle == robot for f in fields)
    assert robot.lookahead == pytest.approx((0.2 - 0.05) / 2)
    headings = {tuple(f.initial_headings) for f in fields}
    assert len(headings) == 3  # drawn per field
    assert all(f.control.safety_margin >= f.body_reach for f in fields)
    code, rep = _campaign("--fields", "4", "--kinematics", "unicycle", "--jobs", "2")
    assert code == 0 and rep["kinematics"] == "unicycle" and rep["sets"]["inside"]["collided"] == 0


def test_unicycles_run_a_finer_tick_where_the_fields_speed_limit_asks_more_than_l_over_dt() -> None:
    """crossing sets 2 m/s; its unicycles (l = 0.05 m) reach at most l/dt = 1 m/s at its 20 Hz,
    so its fields run 3 ticks for each of crossing's (3 m/s > 2), the tolerance kept in metres;
    obstacles sets none, and its unicycle fields keep its tick (and their bits)."""
    crossing, obstacles = load_scenario("crossing"), load_scenario("obstacles")
    robot = unicycle_for(crossing, 2.0)
    assert unicycle_ticks(crossing.dt, robot, 2.0) == 3 and unicycle_ticks(0.05, robot, 0.99) == 1
    assert unicycle_ticks(0.05, robot, 1.0) == 2  # l/dt itself is the map's edge: not within
    assert unicycle_ticks(0.05, robot, None) == 1
    field = make_field(crossing, 1, "inside", FieldOptions(kinematics="unicycle"))
    assert field.dt == crossing.dt / 3 and field.unicycle == robot
    assert field.tolerance == pytest.approx(crossing.tolerance)
    assert field.speed_limit == 2.0 <= robot.fastest_point(field.dt)
    same = make_field(obstacles, 1, "inside", FieldOptions(kinematics="unicycle"))
    assert same.dt == obstacles.dt
    code, rep = _campaign("--base", "crossing", "--fields", "2", "--kinematics", "unicycle",
                          "--jobs", "1")  # fmt: skip
    assert code == 0 and rep["sets"]["inside"]["fields"] == 2
    assert rep["sets"]["inside"]["collided"] == 0


def test_hard_fields_as_unicycles_are_all_in_the_plane_and_none_collides() -> None:
    """--kind hard --kinematics unicycle: every field 2-D (unicycles drive in the plane), each
    the single integrators' field with its agents made unicycles where that stays admissible."""
    field = hard_field(5, 2, unicycles=True)
    assert field.unicycle is not None and field.control.safety_margin >= field.body_reach
    plain = hard_field(5, 2)
    assert field.obstacles == plain.obstacles and field.path == plain.path
    code, rep = _campaign("--kind", "hard", "--fields", "3", "--kinematics", "unicycle",
                          "--jobs", "2")  # fmt: skip
    assert code == 0 and set(rep["sets"]) == {"hard/2d"}
    assert rep["sets"]["hard/2d"]["fields"] == 3 and rep["sets"]["hard/2d"]["collided"] == 0


def test_unicycles_are_refused_where_they_cannot_go() -> None:
    grid = CliRunner().invoke(main, ["scenarios", "new", "-n", "6", "--dim", "3"])
    assert grid.exit_code == 0, grid.output
    with pytest.raises(FieldError, match="drive in the plane"):
        make_field(parse_scenario(grid.stdout), 0, "inside", FieldOptions(kinematics="unicycle"))
