"""world/assumptions.py beyond the paper's Assumptions (those are in test_loader.py): what makes
a field impossible to finish, refused at load with the field named."""

from __future__ import annotations

import copy
from typing import Any

import pytest

from shoal.world.errors import ScenarioError
from shoal.world.loader import scenario_from_dict


def base() -> dict[str, Any]:
    """Four agents on a 20 m leg; final slots (17, 3), (17, -3), (14, 0); no obstacle."""
    return {
        "dt": 0.01,
        "duration": 25.0,
        "graph": {"edges": [[1, 2], [1, 3], [2, 3], [2, 4], [3, 4]]},
        "agents": [{"offset": o} for o in ([0, 0], [-3, 3], [-3, -3], [-6, 0])],
        "leader": {"waypoints": [[0, 0], [20, 0]], "speed": 1.0},
    }


def with_(data: dict[str, Any], **fields: Any) -> dict[str, Any]:
    return {**copy.deepcopy(data), **fields}


def walker(
    centre: list[float], to: list[float], speed: float = 1.0, loop: bool = False
) -> dict[str, Any]:
    """A moving obstacle of radius 0.3 m walking from ``centre`` to ``to`` (and back: ``loop``)."""
    moves = {"kind": "route", "waypoints": [to], "speed": speed, "loop": loop}
    return {"centre": centre, "radius": 0.3, "moves": moves}


# -- obstacles are named by their place in the list ---------------------------------------------


def test_a_standing_obstacle_after_a_moving_one_is_named_by_its_own_index() -> None:
    data = with_(base(), obstacles=[walker([5, 8], [5, 9]), {"centre": [-3, 3.3], "radius": 0.5}])
    message = r"^agents\[1\]\.offset: agent 2 starts inside obstacles\[1\]$"  # no initial: offset
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(data)


# -- every demanded shape keeps its slots the separation apart ----------------------------------


def grid(scale: float, **extra: Any) -> dict[str, Any]:
    """16 agents on a grid 0.5 m apart, the leader at a corner, shrunk by ``scale``
    at 2 s: 0.5 / 2 = 0.25 m < 0.4 m stood gridlocked for 45 s before it was refused."""
    cells = [(r, c) for r in range(4) for c in range(4)]
    ids = {cell: k + 1 for k, cell in enumerate(cells)}
    edges = [[ids[r, c], ids[r + dr, c + dc]] for r, c in cells for dr, dc in ((0, 1), (1, 0))
             if (r + dr, c + dc) in ids]  # fmt: skip
    shape = {"graph": {"edges": edges}, "reshape": [{"at": 2.0, "scale": scale}],
             "agents": [{"offset": [-0.5 * c, 0.5 * r]} for r, c in cells]}  # fmt: skip
    return with_(base(), **(shape | extra))


SHRUNK = "agents 1 and 2 would be meant to be {} m apart, closer than the separation 0.4 m"


@pytest.mark.parametrize(("scale", "gap"), [(2.0, "0.25"), (1.26, "0.397")])
def test_a_reshape_into_slots_closer_than_the_separation_is_refused(scale: float, gap: str) -> None:
    message = rf"^reshape\[0\]\.scale: {SHRUNK.format(gap)} the safety filter keeps; the " + (
        "formation could never take this shape$"
    )
    with pytest.raises(ScenarioError, match=message) as info:
        scenario_from_dict(grid(scale))
    assert info.value.field == "reshape[0].scale"


def test_a_later_reshape_is_checked_too_and_named() -> None:
    data = grid(1.0)
    data["reshape"] = [{"at": 2.0, "scale": 1.2, "rotate": 1.0}, {"at": 4.0, "scale": 2.0}]
    with pytest.raises(ScenarioError, match=r"^reshape\[1\]\.scale: agents 1 and 2 would be"):
        scenario_from_dict(data)


@pytest.mark.parametrize(
    "data",
    [
        grid(1.25),  # 0.5 / 1.25 = 0.4: exactly the separation
        grid(2.0, control={"separation": 0.25}),
        grid(2.0, control={"safety": "paper"}),  # nothing keeps agents apart without the filter
        grid(2.0, reshape=[{"at": 2.0, "scale": 2.0}, {"at": 2.0, "scale": 1.0}]),  # replaced
        grid(2.0, reshape=[{"at": 25.0, "scale": 2.0}]),  # at the run's end: never applied
    ],
    ids=["at-the-separation", "smaller-separation", "paper", "replaced", "at-the-end"],
)
def test_a_reshape_no_tick_demands_closer_than_the_separation_loads(data: dict[str, Any]) -> None:
    assert scenario_from_dict(data).n == 16


def close_offsets(gap: float, **extra: Any) -> dict[str, Any]:
    """Agents 3 and 4 meant to be ``gap`` m apart, starting 1 m apart."""
    agents = [{"offset": [0, 0]}, {"offset": [-3, 3]}, {"offset": [0, -3]},
              {"offset": [gap, -3], "initial": [1, -3]}]  # fmt: skip
    return with_(base(), agents=agents, **extra)


def test_offsets_closer_than_the_separation_are_refused() -> None:
    message = (
        r"^agents\[3\]\.offset: agents 3 and 4 are meant to be 0\.39 m apart, closer than "
        r"the separation 0\.4 m the safety filter keeps; the formation could never take"
    )
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(close_offsets(0.39))
    assert scenario_from_dict(close_offsets(0.4)).n == 4


def test_offsets_a_reshape_replaces_from_the_start_are_not_demanded() -> None:
    """Offsets written in other units and scaled at tick 0: only the scaled shape is asked for."""
    assert scenario_from_dict(close_offsets(0.3, reshape=[{"at": 0.0, "scale": 0.5}])).n == 4
    with pytest.raises(ScenarioError, match=r"^agents\[3\]\.offset: agents 3 and 4 are meant"):
        scenario_from_dict(close_offsets(0.3, reshape=[{"at": 0.01, "scale": 0.5}]))


# -- every final slot can be reached -----------------------------------------------------------


def post(centre: list[float], radius: float = 1.0, **extra: Any) -> dict[str, Any]:
    """base() with one standing obstacle."""
    return with_(base(), obstacles=[{"centre": centre, "radius": radius}], **extra)


def test_a_final_slot_inside_a_guard_circle_is_refused() -> None:
    message = (
        r"^agents\[1\]\.offset: the final slot of agent 2 lies 0\.1 m from the edge of "
        r"obstacles\[0\], inside its guard circle ρ = 0\.2 m: the safety filter keeps the "
        r"agent out of it, so the formation can never arrive in its final shape$"
    )
    with pytest.raises(ScenarioError, match=message) as info:
        scenario_from_dict(post([17, 4.1]))  # agent 2's slot is (17, 3)
    assert info.value.field == "agents[1].offset"
    inside = r"^agents\[1\]\.offset: .* agent 2 lies inside obstacles\[0\] by 0\.3 m"
    with pytest.raises(ScenarioError, match=inside):
        scenario_from_dict(post([17, 3.2], 0.5))  # in the obstacle itself


RHO = {"control": {"safety_margin": 0.25}}  # ρ and the distances below exact in binary


@pytest.mark.parametrize(("y", "loads"), [(3.75, True), (3.76, True), (3.74, False)])
def test_a_final_slot_on_the_guard_circle_loads_and_one_inside_it_does_not(
    y: float, loads: bool
) -> None:
    data = post([17, y], 0.5, **RHO)  # the slot (17, 3) is y - 3.5 from the guard circle
    if loads:
        assert scenario_from_dict(data).n == 4
    else:
        with pytest.raises(ScenarioError, match=r"agent 2 lies 0\.24 m .* guard circle ρ = 0\.25"):
            scenario_from_dict(data)


def test_the_last_reshape_places_the_final_slots() -> None:
    """Turned by π/2 at 10 s, agent 2's slot (17, 3) moves to (17, -3); shrunk ×2, to
    (18.5, 1.5)."""
    turned = {"reshape": [{"at": 10.0, "rotate": 1.5707963267948966}]}
    assert scenario_from_dict(post([17, 4.1], **turned)).n == 4
    with pytest.raises(ScenarioError, match=r"^agents\[1\]\.offset: the final slot of agent 2"):
        scenario_from_dict(post([17, -4.1], **turned))
    with pytest.raises(ScenarioError, match=r"^agents\[1\]\.offset: the final slot of agent 2"):
        scenario_from_dict(post([18.5, 2.6], reshape=[{"at": 10.0, "scale": 2.0}]))


def test_on_a_sinusoid_the_final_slot_is_where_the_path_is_at_the_last_tick() -> None:
    """The leader's path is at (20, 0) at t = 20 s: the run's last tick for 20.01 s of run."""
    wave = {"sinusoid": {"start": [0, 0], "direction": [1, 0], "speed": 1.0, "amplitude": 2.0,
                         "period": 10.0}}  # fmt: skip
    with pytest.raises(ScenarioError, match=r"^agents\[1\]\.offset: the final slot of agent 2 "):
        scenario_from_dict(post([17, 4.1], leader=wave, duration=20.01))
    assert scenario_from_dict(post([17, 4.1], leader=wave, duration=25.0)).n == 4


def test_without_the_filter_a_final_slot_in_a_guard_loads() -> None:
    assert scenario_from_dict(post([17, 4.1], control={"safety": "paper"})).n == 4


@pytest.mark.parametrize(
    ("to", "speed", "duration", "agent"),
    [([17, 3.5], 1.0, 25.0, 2), ([20, 0.4], 1.0, 25.0, 1), ([17, 3.5], 0.1, 60.0, 2)],
    ids=["follower", "leader", "slow-but-in-time"],
)
def test_a_walker_that_stops_in_a_final_slot_is_refused(
    to: list[float], speed: float, duration: float, agent: int
) -> None:
    """A route walker that stops keeps agents r + ρ + u·dt = 0.3 + 0.2 + u·0.01 m away."""
    data = with_(base(), obstacles=[walker([17, 8], to, speed)], duration=duration)
    edge = round(0.5 - 0.3, 3) if agent == 2 else round(0.4 - 0.3, 3)
    message = (
        rf"^obstacles\[0\]\.moves: it stops for good at its last waypoint, its edge {edge} "
        rf"m from the final slot of agent {agent}, within ρ \+ u·dt = "
    )
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(data)


@pytest.mark.parametrize(
    "walking",
    [
        walker([17, 8], [17, 3.52]),  # 0.52 m from the slot, beyond 0.3 + 0.2 + 0.01
        walker([17, 8], [17, 3.5], speed=0.1),  # 4.5 m at 0.1 m/s: still walking at 25 s
        walker([17, 8], [17, 3.5], loop=True),
    ],
    ids=["beyond-its-guard", "on-its-way", "looping"],
)
def test_a_walker_that_does_not_stand_in_a_final_slot_loads(walking: dict[str, Any]) -> None:
    assert scenario_from_dict(with_(base(), obstacles=[walking])).n == 4
