"""What stands between the agents' commands and their robots' motion: one interface, three
layers (docs/safety.md, Realtime and Without a referee), each configured once per run.

- :class:`Referee`: every command filtered again with every agent's true position at the tick
  it is applied (in lockstep every command is already safe for its tick: nothing changes);
- :class:`Onboard`: each robot's own layer, knowing only what its robot knows
  (world/onboard.py);
- :class:`Unguarded`: applied as sent.

The last two also ask the referee, without applying its answer, what it would have changed and
by how much: the summary reports it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from shoal.bus.messages import Sensing
from shoal.bus.types import ControlParams, LimitSide, SafetyLayer
from shoal.geometry.safety import SafetyFilter
from shoal.geometry.vectors import FloatArray
from shoal.world.kinematics import actuate
from shoal.world.onboard import Link, OnboardLayers
from shoal.world.plant import Observed
from shoal.world.reach import Bounds
from shoal.world.reach_layer import Reach


class Layer(Protocol):
    def act(
        self,
        k: int,
        sensings: Sequence[Sensing],
        commanded: FloatArray,
        seen: Observed | None = None,
    ) -> FloatArray:
        """The velocities (n, dim) m/s the robots hold over tick ``k`` for ``commanded``
        (n, dim; a zero row: an agent held still), given the tick's ``sensings`` and what the
        plant ``seen`` of the robots (their poses' ages)."""

    def report(self) -> dict[str, Any]:
        """Summary entries: which layer, what it changed (docs/wire.md)."""


def referee_filters(
    params: ControlParams, n: int, dt: float, limits: Sequence[tuple[LimitSide, ...]]
) -> list[SafetyFilter]:
    """Every agent's own filter, as the referee applies it (none with ``safety: paper``)."""
    if not params.filtered:
        return []
    return [SafetyFilter.of(params, i + 1, dt, limits[i] if limits else ()) for i in range(n)]


class Referee:
    """Filters every command again with the tick's fresh sensing."""

    def __init__(self, filters: Sequence[SafetyFilter]) -> None:
        self.filters = filters
        self.corrected = 0  # agent-ticks whose command it changed

    def act(
        self,
        k: int,
        sensings: Sequence[Sensing],
        commanded: FloatArray,
        seen: Observed | None = None,
    ) -> FloatArray:
        velocities, fixed = actuate(sensings, commanded, self.filters)
        self.corrected += fixed
        return velocities

    def report(self) -> dict[str, Any]:
        return {
            "actuator_corrections": self.corrected,
            "safety_layer": str(SafetyLayer.REFEREE),
            "layer_standing": None,
            "referee_would_correct": None,
            "referee_largest_change": None,
        }


class _Watched:
    """What a referee would have changed of the velocities a layer lets through."""

    def __init__(self, filters: Sequence[SafetyFilter]) -> None:
        self.referee = filters
        self.would = 0  # agent-ticks a referee would have changed
        self.largest = 0.0  # m/s: the most it would have changed one

    def watch(self, sensings: Sequence[Sensing], velocities: FloatArray) -> None:
        fixed_velocities, fixed = actuate(sensings, velocities, self.referee)
        if fixed:
            self.would += fixed
            change = np.linalg.norm(fixed_velocities - velocities, axis=1).max(initial=0.0)
            self.largest = max(self.largest, float(change))  # m/s

    def entries(self, layer: SafetyLayer, corrected: int, standing: int | None) -> dict[str, Any]:
        return {
            "actuator_corrections": corrected,
            "safety_layer": str(layer),
            "layer_standing": standing,
            "referee_would_correct": self.would,
            "referee_largest_change": self.largest,
        }


class Unguarded(_Watched):
    """Commands applied as sent."""

    def act(
        self,
        k: int,
        sensings: Sequence[Sensing],
        commanded: FloatArray,
        seen: Observed | None = None,
    ) -> FloatArray:
        self.watch(sensings, commanded)
        return commanded

    def report(self) -> dict[str, Any]:
        return self.entries(SafetyLayer.NONE, 0, None)


class Onboard(_Watched):
    """Each robot's own layer (world/onboard.py)."""

    def __init__(self, filters: Sequence[SafetyFilter], layers: OnboardLayers) -> None:
        super().__init__(filters)
        self.layers = layers
        self.changed = 0  # agent-ticks whose command a robot's layer changed
        self.standing = 0  # robot-ticks held still waiting for a neighbour's snapshot

    def act(
        self,
        k: int,
        sensings: Sequence[Sensing],
        commanded: FloatArray,
        seen: Observed | None = None,
    ) -> FloatArray:
        held = self.layers.act(k, sensings, commanded)
        self.changed += held.changed
        self.standing += held.standing
        self.watch(sensings, held.velocities)
        return held.velocities

    def report(self) -> dict[str, Any]:
        return self.entries(SafetyLayer.ONBOARD, self.changed, self.standing)


def make_layer(
    kind: SafetyLayer,
    params: ControlParams,
    n: int,
    dt: float,
    limits: Sequence[tuple[LimitSide, ...]] = (),
    *,
    epoch: int = 2,
    link: Link | None = None,
    bounds: Sequence[Bounds] = (),
    largest_obstacle: float = 0.0,
) -> Layer:
    """The layer ``kind`` for a run of ``n`` agents; ``epoch`` (ticks between the robots'
    snapshots) and ``link`` (their radio) for the onboard layer; the robots' ``bounds`` (none
    given: robots that move as commanded) and the ``largest_obstacle``'s radius (m) for the
    reach layer."""
    if kind == SafetyLayer.REACH:
        if any(limits):
            raise ValueError("the reach layer is for single integrators; unicycles are not yet")
        if not params.filtered:
            raise ValueError("the reach layer certifies steps, and safety: paper asks for none")
        return Reach(params, dt, tuple(bounds) or (Bounds(),) * n, largest_obstacle)
    filters = referee_filters(params, n, dt, limits)
    if kind == SafetyLayer.REFEREE:
        return Referee(filters)
    if kind == SafetyLayer.NONE:
        return Unguarded(filters)
    return Onboard(filters, OnboardLayers(params, dt, epoch, link or Link(), n, limits))
