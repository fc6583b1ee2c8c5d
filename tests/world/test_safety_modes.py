"""``control.safety``: the filter is the default and changes nothing where it is not needed;
``safety: paper`` is Algorithm 2 alone, bit for bit the trajectories of shoal before the
filter; the load-time checks of the filter's theorem name the field they refuse."""

from __future__ import annotations

import dataclasses
import hashlib

import pytest
from triangle import triangle

from shoal.tools.simulator import simulate
from shoal.world.errors import ScenarioError
from shoal.world.loader import load_scenario, parse_scenario, scenario_from_dict
from shoal.world.metrics import clearances, summarize
from shoal.world.scenario import Scenario

# sha256 (first 32 hex digits) of the float64 positions of each built-in as simulated before
# the safety filter existed (commit 8bf9d1e): the paper mode must keep reproducing them.
BEFORE_THE_FILTER = {
    "default": "7f96f719c0cdf330dc4d610be3bb40ec",
    "obstacles": "8a281472a39acbfe19e5ac45974a0846",
    "passage": "66f61dacced0e9793ed9d3c08c9b0ca5",
    "sinusoid": "f4a931f8cfdcc281acc241d443939dff",
}


# default's second obstacle lay 8.3 m past the end of the route, never sensed; it has moved
# beside the second leg since. The historic digest is of default as it was then.
AS_IT_WAS = {"default": ("centre: [15.6, 12], radius: 1.0", "centre: [15.6, 27], radius: 1.0")}


def _digest(positions: object) -> str:
    return hashlib.sha256(positions.tobytes()).hexdigest()[:32]  # type: ignore[attr-defined]


@pytest.mark.parametrize("name", sorted(BEFORE_THE_FILTER))
def test_paper_mode_reproduces_the_trajectories_from_before_the_filter(name: str) -> None:
    scn = load_scenario(name)
    if name in AS_IT_WAS:
        now, then = AS_IT_WAS[name]
        assert now in scn.source
        scn = parse_scenario(scn.source.replace(now, then))
    paper = dataclasses.replace(scn, control=dataclasses.replace(scn.control, safety="paper"))
    traj = simulate(paper)
    assert _digest(traj.positions) == BEFORE_THE_FILTER[name]
    assert not traj.filtered.any()


def _unlimited(scn: Scenario) -> Scenario:
    """``scn`` without its speed limit: the largest the theorem admits."""
    return dataclasses.replace(scn, control=dataclasses.replace(scn.control, speed_limit=None))


def test_the_filter_is_on_by_default_and_idle_on_the_builtins() -> None:
    """The built-ins never bring an agent to a guard circle or a neighbour's cell, so the
    filter never acts on them; without obstacles (the sinusoid) the run is the paper's bit for
    bit. Every built-in ends in formation, outside every guard. Their speed limit is left out:
    since 2026-12-08 they carry 4 m/s, whose cap (which counts as the filter acting) trims the
    law's transients in 0.7–4.3 % of agent-ticks; no row ever acts."""
    for name in BEFORE_THE_FILTER:
        scn = _unlimited(load_scenario(name))
        assert scn.control.safety == "filter" and scn.params().filtered
        traj = simulate(scn)
        assert not traj.filtered.any(), name
        summary = summarize(scn, traj)
        assert summary.final_formation_error <= summary.tolerance, name
        if scn.obstacles:
            assert float(clearances(scn, traj).min()) >= scn.control.safety_margin - 1e-9, name
    sinusoid = simulate(_unlimited(load_scenario("sinusoid")))
    assert _digest(sinusoid.positions) == BEFORE_THE_FILTER["sinusoid"]


def _base(**control: object) -> dict[str, object]:
    return triangle([[0, 0], [10, 0]], duration=1.0, obstacle=([5, 3], 1.0), **control)


@pytest.mark.parametrize(
    ("change", "field", "message"),
    [
        ({"control": {"speed_limit": 500.0}}, "control.speed_limit", r"exceeds min\(d − r_max"),
        ({"control": {"safety_margin": 0.01}}, "control.safety_margin", "agent_radius"),
        ({"control": {"separation": 0.05}}, "control.separation", "2·agent_radius"),
        ({"control": {"safety": "off"}}, "control.safety", "filter, paper"),
        (
            {"agents": [{"offset": [0, 0]}, {"offset": [-3, 3], "initial": [0.2, 0.1]},
                        {"offset": [-3, -3]}]},
            "agents[1].initial", "closer than the separation",
        ),
        (
            {"agents": [{"offset": [0, 0]}, {"offset": [-3, 3], "initial": [5.0, 1.9]},
                        {"offset": [-3, -3]}]},
            "agents[1].initial", "inside its guard circle",
        ),
        (
            {"obstacles": [{"centre": [5, 3], "radius": 1.0}, {"centre": [7.3, 3], "radius": 1.0}]},
            "obstacles[1]", "wedged in the notch",
        ),
    ],
)  # fmt: skip
def test_what_the_filters_theorem_needs_is_checked_at_load(
    change: dict[str, object], field: str, message: str
) -> None:
    data = _base()
    for key, value in change.items():
        data[key] = {**data[key], **value} if key == "control" else value  # type: ignore[dict-item]
    with pytest.raises(ScenarioError, match=message) as refused:
        scenario_from_dict(data)
    assert refused.value.field == field


def test_paper_mode_needs_none_of_the_filters_checks() -> None:
    data = _base(safety="paper", safety_margin=0.01)
    data["obstacles"] = [{"centre": [5, 3], "radius": 1.0}, {"centre": [7.3, 3], "radius": 1.0}]
    assert scenario_from_dict(data).control.safety == "paper"


def test_the_default_speed_limit_is_the_largest_the_theorem_admits() -> None:
    scn = scenario_from_dict(_base())
    # min(d − r_max − ρ, (d − 2R)/2) / dt = min(5 − 1 − 0.2, (5 − 0.4)/2) / 0.01
    assert scn.speed_limit == pytest.approx(230.0)
    assert scn.params().speed_limit == scn.speed_limit
    capped = scenario_from_dict(_base(speed_limit=3.0))
    assert capped.params().speed_limit == 3.0


def test_a_scenario_file_can_turn_the_filter_off() -> None:
    text = load_scenario("obstacles").source.replace("control:\n", "control:\n  safety: paper\n")
    assert parse_scenario(text).control.safety == "paper"
