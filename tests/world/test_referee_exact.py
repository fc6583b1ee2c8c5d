"""In lockstep every command an agent sends is already safe for its tick, so the world's referee
must change none of them, bit for bit — unicycles included, whose limits are a polygon of point
velocities the agent's own filter caps its command onto — and a run without a referee must be
the same run. (A command on an edge of the polygon up to rounding is inside it: before, the
referee scaled about 160 commands per `robotarium` run by less than 1e-16 m/s, and a run with
`--safety-layer none` parted from the reference at tick 312.)"""

from __future__ import annotations

from collections.abc import Callable

import pytest
from physics_cases import mixed_robotarium

from shoal.bus.types import SafetyLayer
from shoal.geometry.safety import cap_to_limits
from shoal.tools.simulator import _commands, reference_step
from shoal.world.layers import make_layer
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.plant import simulated
from shoal.world.scenario import Scenario
from shoal.world.step import Step


def mixed() -> Scenario:
    return parse_scenario(mixed_robotarium(30.0, ("[-0.4, 0.4]}",)), default_name="mixed")


def run(scn: Scenario, layer: SafetyLayer) -> tuple[str, dict[str, object]]:
    if layer == SafetyLayer.REFEREE:
        step = reference_step(scn)
    else:
        s = scn
        chosen = make_layer(layer, s.params(), s.n, s.dt, s.limits)
        step = Step(s, chosen, simulated(s))
    for k, reports in _commands(scn, step):
        step.act(k, reports)
    return step.finish().digest(), step.layer.report()


def robotarium() -> Scenario:
    return load_scenario("robotarium")


@pytest.mark.parametrize("make", [robotarium, mixed], ids=["robotarium", "mixed"])
def test_the_referee_changes_nothing_in_lockstep_and_no_referee_is_the_same_run(
    make: Callable[[], Scenario],
) -> None:
    scn = make()
    refereed, report = run(scn, SafetyLayer.REFEREE)
    assert report["actuator_corrections"] == 0
    unguarded, watched = run(scn, SafetyLayer.NONE)
    assert unguarded == refereed and watched["referee_would_correct"] == 0


def test_a_velocity_on_an_edge_up_to_rounding_is_not_scaled() -> None:
    limits = load_scenario("robotarium").limits[0]
    nx, ny, c, _ = limits[0]
    on_edge = (c * nx * (1 + 4e-16), c * ny * (1 + 4e-16))  # heading 0: body frame = world
    assert cap_to_limits(on_edge, limits, 0.0) is on_edge
    outside = (c * nx * 1.001, c * ny * 1.001)
    capped = cap_to_limits(outside, limits, 0.0)
    assert capped != outside and abs(capped[0] * nx + capped[1] * ny - c) < 1e-15
