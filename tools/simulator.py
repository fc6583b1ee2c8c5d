"""The reference simulator: every agent and the world in one process, in lockstep.

It drives the world's own tick (world/step.py: sensing, the referee, the kinematic plant, the
record) with each agent's ``Controller.announce`` / ``Controller.act`` in place of the bus, in
the same order and on the same float64 values as the world process, so a lockstep run over
Zenoh must reproduce its trajectory bit for bit. setup.py compiles it with those modules: a
campaign spends most of its time in this loop.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from shoal.agent.controller import Controller
from shoal.bus.messages import AgentState, TickRecord
from shoal.bus.types import SafetyLayer
from shoal.world.layers import make_layer
from shoal.world.plant import KINEMATICS, Kinematics, bodily, simulated
from shoal.world.reach_layer import reach_inputs
from shoal.world.scenario import Scenario
from shoal.world.step import Report, Step
from shoal.world.trajectory import Trajectory

Progress = Callable[[int], None]


def reference_step(
    scenario: Scenario,
    plant: str = KINEMATICS,
    dynamics: str | None = None,
    layer: SafetyLayer = SafetyLayer.REFEREE,
) -> Step:
    """The tick of ``scenario`` as the reference runs it: the referee (which in lockstep
    changes nothing), or the ``layer`` asked for, and the simulated plant called ``plant``
    (world/plant.py ``simulated``)."""
    s = scenario
    bounds, largest = reach_inputs(s, dynamics)
    chosen = make_layer(
        layer, s.params(), s.n, s.dt, s.limits, bounds=bounds, largest_obstacle=largest
    )
    return Step(s, chosen, simulated(s, plant, dynamics))


def _commands(scenario: Scenario, step: Step) -> Iterator[tuple[int, dict[int, Report]]]:
    """Every tick's number and every agent's report for it, from its controller (each tick's
    sensing from ``step``, which the caller then acts on)."""
    configs = [scenario.agent_config(i + 1) for i in range(scenario.n)]
    if not isinstance(step.plant, Kinematics):  # bodies: as the world configures its agents
        configs = [bodily(c) for c in configs]
    controllers = [Controller(c) for c in configs]
    memories = [c.start() for c in controllers]
    for k in range(scenario.steps):
        sensings = step.sense(k)
        states: dict[int, AgentState] = {}
        for i, c in enumerate(controllers):
            memories[i], states[i + 1] = c.announce(memories[i], sensings[i])
        reports: dict[int, Report] = {}
        for i, c in enumerate(controllers):
            heard = {j: states[j] for j in c.listens_to}
            memories[i], command = c.act(memories[i], sensings[i], heard)
            reports[i + 1] = (states[i + 1], command)
        yield k, reports


def run(
    scenario: Scenario,
    plant: str = KINEMATICS,
    dynamics: str | None = None,
    layer: SafetyLayer = SafetyLayer.REFEREE,
) -> Iterator[TickRecord]:
    """Yield every tick's record of ``scenario`` in order, as the world publishes it; stop
    iterating to stop the run early."""
    step = reference_step(scenario, plant, dynamics, layer)
    everyone = range(1, scenario.n + 1)
    for k, reports in _commands(scenario, step):
        yield step.act_recorded(k, reports, everyone)


def simulate(
    scenario: Scenario,
    *,
    progress: Progress | None = None,
    plant: str = KINEMATICS,
    dynamics: str | None = None,
    layer: SafetyLayer = SafetyLayer.REFEREE,
) -> Trajectory:
    """Run ``scenario`` for all its ticks; ``progress(k)`` is called after each tick."""
    return reference(scenario, progress=progress, plant=plant, dynamics=dynamics, layer=layer)[0]


def reference(
    scenario: Scenario,
    *,
    progress: Progress | None = None,
    plant: str = KINEMATICS,
    dynamics: str | None = None,
    layer: SafetyLayer = SafetyLayer.REFEREE,
) -> tuple[Trajectory, dict[str, Any]]:
    """:func:`simulate`, and its plant's summary entries (a physics run's judgement; the reach
    layer's counts when it is the ``layer``)."""
    step = reference_step(scenario, plant, dynamics, layer)
    for k, reports in _commands(scenario, step):
        step.act(k, reports)
        if progress is not None:
            progress(k)
    extra = step.layer.report() if layer == SafetyLayer.REACH else {}
    return step.finish(), step.plant.report() | extra
