"""The world's live watch on the leader (world/watch.py): it says "leader trapped" when the
summary's rule would, tick by tick, once, and says so again if the leader gets going."""

from __future__ import annotations

import numpy as np
from test_arrival import SLOT, on_route, scenario, times, trajectory

from shoal.world.arrival import arrival, route_left
from shoal.world.watch import LeaderWatch


def _events(s, leader: np.ndarray) -> list[tuple[int, str]]:
    watch = LeaderWatch(s)
    out = []
    for k, p in enumerate(leader[:-1]):
        text = watch.update(k, p)
        if text is not None:
            out.append((k, text))
    return out


def _circling(t: np.ndarray, start: float, stop: float | None = None) -> np.ndarray:
    """The leader on its route, but circling (5, 1) at 1 m/s from ``start`` s (to ``stop``
    s, then on to its goal at (10, 0))."""
    leader = on_route(t)
    during = (t >= start) if stop is None else (t >= start) & (t < stop)
    phase = t[during] - start
    leader[during] = np.stack([5.0 + np.sin(phase), 1.0 - np.cos(phase)], axis=1)
    if stop is not None:
        after = t >= stop
        leader[after] = np.stack([np.minimum(5.0 + (t[after] - stop), 10.0), 0 * t[after]], 1)
    return leader


def test_a_leader_circling_for_good_is_reported_trapped_once_as_the_summary_says() -> None:
    s, t = scenario(), times()
    leader = _circling(t, 5.0)
    events = _events(s, leader)
    assert len(events) == 1 and events[0][1].startswith("leader trapped: no progress")
    assert arrival(s, trajectory(leader, leader + SLOT)).cause == "leader trapped"
    # the tick it fires is the first at which the summary's rule holds
    left = route_left(s.path, leader[:-1], 0.2 + s.path.speed * s.dt, s.dt)
    p = 100
    first = next(k for k in range(p, len(left)) if left[k] > left[: k - p + 1].min() - 0.2)
    assert events[0][0] == first


def test_a_leader_that_gets_going_again_is_reported_moving() -> None:
    s, t = scenario(), times()
    leader = _circling(t, 5.0, stop=40.0)
    kinds = [text.split(":")[0].split(",")[0] for _, text in _events(s, leader)]
    assert kinds == ["leader trapped", "leader moving again"]
    assert arrival(s, trajectory(leader, leader + SLOT)).arrived


def test_a_leader_on_its_way_and_home_is_never_reported() -> None:
    s, t = scenario(), times()
    assert _events(s, on_route(t)) == []


def test_the_world_logs_a_trapped_leader_while_the_run_goes_on(monkeypatch) -> None:
    """The world loop on a memory bus, with a leader made to circle (2, 0) instead of leading
    (its ``lead`` replaced): the world logs "leader trapped" at the tick the summary's rule first
    holds on the recorded positions, once, and the summary says the same."""
    import math

    from test_loops import RUN, recorded, run_in_memory

    import shoal.agent.controller as controller
    from shoal.bus import codec
    from shoal.bus.keys import Keys
    from shoal.bus.memory import MemoryBus
    from shoal.world.loader import scenario_from_dict

    def circle(position, route, speed, _dt, reach):  # type: ignore[no-untyped-def]
        x, y = position[0] - 2.0, position[1]
        size = math.hypot(x, y)
        return (-speed * y / size, speed * x / size), route

    monkeypatch.setattr(controller, "lead", circle)
    field = {
        "dt": 0.05, "duration": 24.0,
        "graph": {"edges": [[1, 2], [2, 3], [1, 3]]},
        "agents": [{"offset": [0, 0]}, {"offset": [-3, 3]}, {"offset": [-3, -3]}],
        "leader": {"waypoints": [[0, 0], [16, 0]], "speed": 1.0},
    }  # fmt: skip
    scn = scenario_from_dict(field)
    bus = MemoryBus()
    summary, errors = run_in_memory(scn, bus)
    assert not errors, errors
    events = [codec.decode_event(p) for k, p in bus.published if k == Keys(RUN).event]
    trapped = [e for e in events if e.text.startswith("leader trapped")]
    assert len(trapped) == 1 and trapped[0].agent == 1 and trapped[0].level == 3
    leader = recorded(bus, scn.dt).positions[:-1, 0]
    left = route_left(scn.path, leader, 0.2 + scn.path.speed * scn.dt, scn.dt)
    p = round(10.0 / scn.dt)
    first = next(k for k in range(p, len(left)) if left[k] > left[: k - p + 1].min() - 0.2)
    assert trapped[0].tick == first
    assert summary["leader_trapped"] and summary["not_arrived"] == "leader trapped"
