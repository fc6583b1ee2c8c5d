"""One agent's controller: Algorithm 2's edge dropping, (12), Algorithm 1's epochs, reshapes."""

from __future__ import annotations

import dataclasses
import warnings
from typing import Any

import numpy as np
import pytest

from shoal.agent.controller import Controller, Memory
from shoal.agent.formation import consensus_error, velocity
from shoal.bus.errors import ConfigError
from shoal.bus.messages import AgentState, Sensing
from shoal.world.loader import scenario_from_dict
from shoal.world.scenario import REALTIME_TICKS_PER_ROUND, Scenario


def triangle(**extra: Any) -> Scenario:
    """Leader 1 and followers 2, 3, all linked; agent 2's offset (-2, 2), agent 3's (-2, -2)."""
    data: dict[str, Any] = {
        "dt": 0.01,
        "duration": 1.0,
        "control": {"alpha": 1.0, "beta": 2.0},
        "graph": {"edges": [[1, 2], [1, 3], [2, 3]]},
        "agents": [{"offset": [0, 0]}, {"offset": [-2, 2]}, {"offset": [-2, -2]}],
        "leader": {"waypoints": [[0, 0], [100, 0]], "speed": 1.0},
    }
    data.update(extra)
    return scenario_from_dict(data)


def state(
    agent_id: int, position: tuple[float, float], *, omega: bool = False, bid: float = 1.0
) -> AgentState:
    return AgentState(agent_id, 0, position, omega, bid, 1.0, 0.0)


def sensing(position: tuple[float, float], tick: int = 0, **obstacles: Any) -> Sensing:
    return Sensing(
        tick=tick,
        position=position,
        obstacle_ids=obstacles.get("ids", ()),
        obstacle_centres=obstacles.get("centres", ()),
        obstacle_radii=obstacles.get("radii", ()),
    )


def command_of(c: Controller, me: tuple[float, float], heard: dict[int, AgentState]) -> np.ndarray:
    memory, _ = c.announce(c.start(), sensing(me))
    _, cmd = c.act(memory, sensing(me), heard)
    return np.asarray(cmd.velocity)


def law(
    me: tuple[float, float], my_offset: tuple[float, float], others: list[tuple[Any, Any]]
) -> np.ndarray:
    e = consensus_error(
        np.asarray(me, float),
        np.asarray(my_offset, float),
        np.asarray([p for p, _ in others], float).reshape(len(others), 2),
        np.asarray([o for _, o in others], float).reshape(len(others), 2),
    )
    return velocity(e, alpha=1.0, beta=2.0, boundary_layer=0.0)


def test_follower_uses_every_neighbour_when_nobody_evades() -> None:
    c = Controller(triangle().agent_config(2))
    me, leader, three = (-1.0, 1.5), (0.5, 0.0), (-2.5, -2.0)
    v = command_of(c, me, {1: state(1, leader), 3: state(3, three)})
    expected = law(me, (-2, 2), [(leader, (0, 0)), (three, (-2, -2))])
    assert np.array_equal(v, expected)


def test_neighbour_with_omega_set_is_dropped_and_restored_after() -> None:
    """Algorithm 2: A_23 = 0 while Ω_3 = 1, back to Ā_23 when Ω_3 = 0."""
    c = Controller(triangle().agent_config(2))
    me, leader, three = (-1.0, 1.5), (0.5, 0.0), (-2.5, -2.0)
    only_leader = law(me, (-2, 2), [(leader, (0, 0))])
    both = law(me, (-2, 2), [(leader, (0, 0)), (three, (-2, -2))])
    assert not np.array_equal(only_leader, both)
    evading = command_of(c, me, {1: state(1, leader), 3: state(3, three, omega=True)})
    assert np.array_equal(evading, only_leader)
    restored = command_of(c, me, {1: state(1, leader), 3: state(3, three, omega=False)})
    assert np.array_equal(restored, both)


def test_missing_neighbour_is_treated_as_gone() -> None:
    c = Controller(triangle().agent_config(2))
    me, leader = (-1.0, 1.5), (0.5, 0.0)
    assert np.array_equal(
        command_of(c, me, {1: state(1, leader)}), law(me, (-2, 2), [(leader, (0, 0))])
    )


def test_leader_follows_its_path_whatever_it_hears() -> None:
    c = Controller(triangle().agent_config(1))
    v = command_of(c, (0.0, 0.0), {2: state(2, (5.0, 5.0), omega=True)})
    assert v == pytest.approx([1.0, 0.0])


def test_obstacle_ahead_sets_omega_and_pushes_the_agent_away() -> None:
    scenario = triangle(obstacles=[{"centre": [20.0, 2.3], "radius": 1.0}])
    c = Controller(scenario.agent_config(2))
    me = (17.0, 2.0)  # heading +x; the obstacle is 3 m ahead, 0.3 m to the left of its path
    obstacle = {"ids": (0,), "centres": ((20.0, 2.3),), "radii": (1.0,)}
    memory = Memory(smoothed=np.array([1.0, 0.0]), evasion=None, bid=1.0, sigma_consensus=1.0)
    memory, announced = c.announce(memory, sensing(me, **obstacle))
    assert announced.omega
    assert memory.evasion is not None
    # u^o points from the obstacle towards the path (−y), by r + ρ + ε − d = 1 + 0.2 + 0.05 − 0.3.
    assert memory.evasion.offset == pytest.approx([0.0, -0.95])
    # In formation (at its slot), the agent now moves towards −y, away from the obstacle.
    leader, three = (19.0, 0.0), (17.0, -2.0)
    _, cmd = c.act(memory, sensing(me, **obstacle), {1: state(1, leader), 3: state(3, three)})
    assert cmd.velocity[1] < 0


def test_an_episode_ends_when_the_way_to_the_slot_is_clear_though_the_heading_is_not() -> None:
    """With the safety filter an agent far from its slot ends its episode once the straight
    way to the slot passes clear of the guard, even with its heading still at the obstacle
    (sliding round a guard circle, the heading is along it: the episode never ended and the
    agent went round and round). An agent in its slot keeps the paper's episode."""
    scenario = triangle(obstacles=[{"centre": [20.0, 2.3], "radius": 1.0}])
    c = Controller(scenario.agent_config(2))
    obstacle = {"ids": (0,), "centres": ((20.0, 2.3),), "radii": (1.0,)}
    leader, three = (19.0, 0.0), (17.0, -2.0)  # agent 2's slot: (17, 2)
    heard = {1: state(1, leader), 3: state(3, three)}
    start = Memory(smoothed=np.array([1.0, 0.0]), evasion=None, bid=1.0, sigma_consensus=1.0)
    away = (17.0, 1.6)  # 0.4 m below its slot; the way up is clear, the heading +x is not
    memory, announced = c.announce(start, sensing(away, **obstacle))
    assert announced.omega and memory.evasion is not None
    after, _ = c.act(memory, sensing(away, **obstacle), heard)
    assert after.evasion is None
    in_place = (17.0, 2.0)
    memory, _ = c.announce(start, sensing(in_place, **obstacle))
    after, _ = c.act(memory, sensing(in_place, **obstacle), heard)
    assert after.evasion is not None
    paper = Controller(
        triangle(obstacles=[{"centre": [20.0, 2.3], "radius": 1.0}],
                 control={"alpha": 1.0, "beta": 2.0, "safety": "paper"}).agent_config(2)
    )  # fmt: skip
    memory, _ = paper.announce(start, sensing(away, **obstacle))
    after, _ = paper.act(memory, sensing(away, **obstacle), heard)
    assert after.evasion is not None  # (11) as the paper has it: held until passed


def test_a_follower_bids_for_a_gap_only_in_its_slot_and_calm() -> None:
    """With the safety filter a follower's bid steers σ only when its heading is the
    formation's: not busy (evading, filtered or far from its slot; for up to BUSY_TIME), and,
    once no longer busy, calm for CALM_TAUS heading time constants. Measured: a follower
    expanding back to its slot after a passage headed through the gap by its own motion, bid,
    and σ flipped until the run ended (13 of the 15 unsettled fields in 1,000)."""
    gap = {"ids": (0, 1), "centres": ((20.0, 3.5), (20.0, 0.5)), "radii": (0.5, 0.5)}
    scenario = triangle(
        obstacles=[{"centre": [20.0, 3.5], "radius": 0.5}, {"centre": [20.0, 0.5], "radius": 0.5}],
        leader={"waypoints": [[0, -10], [100, -10]], "speed": 1.0},  # clear of the gap
    )
    c = Controller(scenario.agent_config(2))
    slot = (17.0, 2.0)  # in line with the gap, heading +x through it
    heard = {1: state(1, (19.0, 0.0)), 3: state(3, (17.0, -2.0))}
    calm = dataclasses.replace(c.start(), smoothed=np.array([1.0, 0.0]))
    assert calm.calm == c.calm_ticks == 150  # 3 × 0.5 s at dt = 0.01 s

    def bid(memory: Memory) -> float:
        return c.announce(memory, sensing(slot, **gap))[1].bid

    assert bid(calm) == pytest.approx(2 * np.hypot(2, 2) / 1.5)  # 2·formation radius / usable
    assert bid(dataclasses.replace(calm, calm=c.calm_ticks - 1)) == 1.0
    assert bid(dataclasses.replace(calm, busy=c.busy_ticks, calm=0)) == 1.0
    long_busy = dataclasses.replace(calm, busy=c.busy_ticks + 1, calm=0)
    assert bid(long_busy) > 1.0  # busy longer than BUSY_TIME: the hold is bounded

    memory, _ = c.announce(dataclasses.replace(calm, calm=7), sensing(slot, **gap))
    after, _ = c.act(memory, sensing(slot, **gap), heard)
    assert (after.busy, after.calm) == (0, 8)
    away = (17.0, 1.0)  # 1 m off its slot, 0.5 m per neighbour: above the 0.2 m band
    memory, _ = c.announce(dataclasses.replace(calm, calm=7), sensing(away, **gap))
    after, _ = c.act(memory, sensing(away, **gap), heard)
    assert (after.busy, after.calm) == (1, 0)


def test_agreed_sigma_applies_from_the_next_epoch_for_everyone() -> None:
    scenario = triangle()
    rounds = scenario.rounds
    assert rounds == 1  # a triangle has diameter 1
    c = Controller(scenario.agent_config(3))
    memory = c.start()
    sigmas = []
    for tick in range(4):
        memory, announced = c.announce(memory, sensing((-2.0, -2.0), tick))
        sigmas.append(announced.sigma)
        bid = 3.0 if tick == 0 else 1.0  # agent 2 sees a passage only at tick 0
        memory, _ = c.act(memory, sensing((-2.0, -2.0), tick), {2: state(2, (-2.0, 2.0), bid=bid)})
    assert sigmas == [1.0, 3.0, 1.0, 1.0]


def test_a_bid_from_the_last_epoch_is_not_taken_into_this_one() -> None:
    """Realtime: an agent acts on the freshest state it has of a neighbour, which may be from
    the last epoch and carry a value Algorithm 1 has since reset. Taken into the maximum, a
    passage's old bid went round for good: σ flipped and the formation never expanded."""
    c = Controller(triangle().agent_config(3))  # L_G = 1: every tick is an epoch
    memory, _ = c.announce(c.start(), sensing((-2.0, -2.0), 1))
    old = AgentState(2, 0, (-2.0, 2.0), False, 4.0, 1.0, 0.0)  # tick 0: the last epoch
    after, _ = c.act(memory, sensing((-2.0, -2.0), 1), {2: old})
    assert after.bid == 1.0
    fresh = dataclasses.replace(old, tick=1)
    after, _ = c.act(memory, sensing((-2.0, -2.0), 1), {2: fresh})
    assert after.bid == 4.0


def test_realtime_epochs_are_longer_and_lockstep_ones_are_l_g() -> None:
    scenario = triangle()
    assert scenario.agent_config(2).params.rounds == scenario.rounds == 1
    realtime = scenario.agent_config(2, "realtime").params.rounds
    assert realtime == REALTIME_TICKS_PER_ROUND * scenario.rounds == 4


def test_reshape_schedule_sets_scale_and_rotation_from_its_tick() -> None:
    scenario = triangle(reshape=[{"at": 0.5, "scale": 2.0, "rotate": 0.3}])
    c = Controller(scenario.agent_config(2))
    assert c.shape(49, 1.0) == (1.0, 0.0)
    assert c.shape(50, 1.0) == (2.0, 0.3)
    assert c.shape(50, 4.0) == (8.0, 0.3)  # demanded scale times the agreed contraction


def test_a_bad_config_cannot_be_made_and_names_its_field() -> None:
    cfg = triangle().agent_config(2)
    from dataclasses import replace

    with pytest.raises(ConfigError, match="offset"):
        replace(cfg, offset=(1.0, 2.0, 3.0))
    with pytest.raises(ConfigError, match=r"params\.rounds"):
        replace(cfg, params=replace(cfg.params, rounds=0))


@pytest.mark.parametrize("safety", ["filter", "paper"])
def test_a_follower_whose_neighbours_all_evade_follows_them_with_the_filter(safety: str) -> None:
    """Algorithm 2 drops every evading neighbour, so a follower whose neighbours all evade has
    none and stands still (Assumption 2 broken in the run). With the safety filter it follows
    them all the same (measured: such a follower stood still behind the formation for good);
    the paper mode keeps Algorithm 2 as it is."""
    c = Controller(triangle(control={"alpha": 1.0, "beta": 2.0, "safety": safety}).agent_config(2))
    me, leader, three = (-1.0, 1.5), (0.5, 0.0), (-2.5, -2.0)
    v = command_of(c, me, {1: state(1, leader, omega=True), 3: state(3, three, omega=True)})
    if safety == "paper":
        assert np.array_equal(v, [0.0, 0.0])
    else:
        assert np.array_equal(v, law(me, (-2, 2), [(leader, (0, 0)), (three, (-2, -2))]))


@pytest.mark.parametrize("safety", ["filter", "paper"])
def test_a_heading_slower_than_the_chatter_floor_has_no_ray_with_the_filter(safety: str) -> None:
    """β = 2, dt = 0.01, τ = 0.5 s: the floor is β·√(2k/(2 − k)) ≈ 0.283 m/s. The same
    obstacle as above, straight ahead of a heading just under it: with the filter no collision
    course (a follower at rest has no direction); in the paper's mode (11) as printed."""
    scenario = triangle(
        obstacles=[{"centre": [20.0, 2.3], "radius": 1.0}], control={"safety": safety}
    )
    c = Controller(scenario.agent_config(2))
    k = 1.0 - np.exp(-0.01 / 0.5)
    floor = 2.0 * np.sqrt(2 * k / (2 - k))
    assert c.still_below == (pytest.approx(floor) if safety == "filter" else 0.0)
    obstacle = {"ids": (0,), "centres": ((20.0, 2.3),), "radii": (1.0,)}
    for speed, fires in ((0.99 * floor, safety == "paper"), (1.01 * floor, True)):
        memory = Memory(smoothed=(speed, 0.0), evasion=None, bid=1.0, sigma_consensus=1.0)
        _, announced = c.announce(memory, sensing((17.0, 2.0), **obstacle))
        assert announced.omega is fires, speed


def test_a_formation_at_rest_beside_an_obstacle_stops_evading_and_arrives() -> None:
    """A field kept from the hard generator: at its goal, next to an obstacle, the followers'
    chatter-only headings set Ω 161 times in the last 10 s and it never arrived."""
    from pathlib import Path

    from shoal.tools.simulator import simulate
    from shoal.world.errors import DetourWarning
    from shoal.world.loader import load_scenario
    from shoal.world.metrics import summarize

    with pytest.warns(DetourWarning):  # the leader's first leg runs through an obstacle
        scn = load_scenario(Path(__file__).parents[1] / "fields" / "evading-at-rest.yaml")
    traj = simulate(scn)
    s = summarize(scn, traj)
    assert s.collisions == 0 and s.arrived and s.livelocks == 0
    last = traj.omega[-round(10.0 / scn.dt) :]
    assert not last.any()  # nobody evades at rest


def _kept_field(name: str) -> tuple[Any, Any, float]:
    """A field of tests/fields run through the reference: (scenario, trajectory, the least
    distance of a final slot outside an obstacle's guard circle r + ρ, m)."""
    from pathlib import Path

    from shoal.tools.simulator import simulate
    from shoal.world.assumptions import final_slots
    from shoal.world.loader import load_scenario

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the usual detour warnings of hard fields
        scn = load_scenario(Path(__file__).parents[1] / "fields" / f"{name}.yaml")
    slots = final_slots(scn)[1:]
    gap = np.linalg.norm(slots[:, None] - scn.obstacle_centres[None], axis=-1)
    gap = gap - scn.obstacle_radii - scn.control.safety_margin
    return scn, simulate(scn), float(gap.min())


def test_a_follower_whose_slot_is_on_a_guard_circle_settles_there() -> None:
    """The slot is closer to the guard circle than the sign term's chatter, β·dt: the filter
    clips the chatter on one side, and keep-going used to carry the follower on round the
    circle each time it passed its slot (it never arrived: a livelock 1.6 m off)."""
    from shoal.world.metrics import summarize

    scn, traj, gap = _kept_field("slot-on-the-guard")
    assert 0.0 < gap < scn.control.beta * scn.dt  # the case: a slot inside the chatter band
    s = summarize(scn, traj)
    assert s.collisions == 0 and s.arrived and s.livelocks == 0


def test_an_evasion_beside_a_slot_just_outside_the_guard_ends() -> None:
    """The slot is less than ε outside r + ρ: an episode that had to wait for the way to the
    slot to clear r + ρ + ε never ended, and the follower stayed off its slot by u^o."""
    from shoal.world.metrics import summarize

    scn, traj, gap = _kept_field("evading-beside-the-slot")
    assert 0.0 < gap < scn.control.epsilon  # the case
    s = summarize(scn, traj)
    assert s.collisions == 0 and s.arrived
    assert not traj.omega[-round(10.0 / scn.dt) :].any()  # nobody evades at the goal


def test_a_follower_pressed_against_the_leader_at_its_goal_goes_round_it() -> None:
    """The follower's slot lies beyond the leader, which stands at its goal: head on against
    it, going nowhere, the follower turns to its right (geometry/safety.py, sidestep's ``held``)."""
    from shoal.world.metrics import summarize

    scn, traj, _gap = _kept_field("behind-the-leader")
    s = summarize(scn, traj)
    assert s.collisions == 0 and s.arrived and s.stalls == 0


def test_an_evasion_that_brought_its_follower_to_rest_is_reaimed_at_its_slot() -> None:
    """At rest below the obstacle it evades, the follower's u^o is taken across the way to its
    set-point (Controller._reaimed): it goes round, and the episode ends."""
    from shoal.world.metrics import summarize

    scn, traj, _gap = _kept_field("evading-at-rest-below")
    s = summarize(scn, traj)
    assert s.collisions == 0 and s.arrived
    assert not traj.omega[-round(10.0 / scn.dt) :].any()
