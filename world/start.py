"""Where real robots start, against where their scenario starts them (docs/ros2.md, Where the
robots start).

Everything the loader certified about a start — the separation and the guards, who senses whom
— it certified for the scenario's starting points. Robots placed by hand are never exactly
there, and a fleet left where another run ended, or another lab's robots on the same ROS domain,
can be anywhere. Two bounds per robot, in metres from its own start:

- **warn** beyond ``body_reach + position_error``: the robot's body no longer covers the point
  it should start at, beyond what the scenario's declared pose error explains. The run goes on
  from where the robots are (the filter judges the true positions), but it is not the start
  that was checked.
- **refuse** beyond ``min(sensing_radius, half the distance to the nearest other start)``. Past
  half that distance the robot may be nearer another agent's start than its own: nothing tells
  it from two robots swapped (namespaces in the wrong order), and within it the robot is nearer
  its own start than any other's. Past the sensing radius the neighbours that should sense it
  from their starts may not, and ones that should not may: the graph the formation starts on is
  not the scenario's. The loader's start check (separation + 4·position_error between starts)
  keeps the refusal bound at or above the warning bound.

Pure numpy: no bus, no clock.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shoal.geometry.vectors import FloatArray
from shoal.world.scenario import Scenario


@dataclass(frozen=True)
class StartBounds:
    """``warn`` m, the same for every robot, and what sets it (``warn_why``); ``refuse`` (n,)
    m, robot i's at index i − 1, and what sets each (``refuse_why``)."""

    warn: float
    warn_why: str
    refuse: FloatArray
    refuse_why: tuple[str, ...]


@dataclass(frozen=True)
class Misplaced:
    """Robot ``agent`` (1-based) starts ``distance`` m from its scenario start, beyond ``bound``
    m; ``refused`` when that bound is the refusal's, ``why`` what sets it."""

    agent: int
    distance: float
    bound: float
    refused: bool
    why: str

    def text(self) -> str:
        """One line naming the robot, the distance and the bound."""
        if self.refused:
            return (
                f"agent {self.agent}'s robot starts {self.distance:.3f} m from its scenario start, "
                f"beyond {self.bound:.3f} m ({self.why}): a fleet left where another run "
                "ended, robots in another order, or another lab's on the same ROS domain? "
                "Place it at its start, or start the scenario where the robots are"
            )
        return (
            f"agent {self.agent}'s robot starts {self.distance:.3f} m from its scenario start, "
            "more "
            f"than {self.bound:.3f} m ({self.why}): the run goes on from where it is, not from "
            "the start the loader checked"
        )


def start_bounds(scn: Scenario) -> StartBounds:
    """The two bounds of every robot of ``scn`` (module docstring)."""
    warn = scn.body_reach + scn.position_error
    starts = scn.initial_positions
    gaps = np.linalg.norm(starts[:, None, :] - starts[None, :, :], axis=-1)
    np.fill_diagonal(gaps, np.inf)
    halfway = gaps.min(axis=1) / 2 if scn.n > 1 else np.array([np.inf])
    sensing = scn.control.sensing_radius
    refuse = np.minimum(halfway, sensing)
    why = tuple(
        f"the sensing radius {sensing:g} m"
        if h >= sensing
        else f"half the way to agent {int(np.argmin(gaps[i])) + 1}'s start"
        for i, h in enumerate(halfway)
    )
    warned = f"its body's reach {scn.body_reach:g} m" + (
        f" + position_error {scn.position_error:g} m" if scn.position_error else ""
    )
    return StartBounds(warn, warned, refuse, why)


def misplaced(positions: FloatArray, scn: Scenario) -> list[Misplaced]:
    """The robots of ``scn`` at ``positions`` (n, dim) m, their points as observed, that start
    beyond a bound: refused beyond the refusal's, else warned beyond the warning's, by id."""
    bounds = start_bounds(scn)
    far = np.linalg.norm(np.asarray(positions) - scn.initial_positions, axis=1)
    out = []
    for i, distance in enumerate(far.tolist()):
        refuse = float(bounds.refuse[i])
        if distance > refuse:
            out.append(Misplaced(i + 1, distance, refuse, True, bounds.refuse_why[i]))
        elif distance > bounds.warn:
            out.append(Misplaced(i + 1, distance, bounds.warn, False, bounds.warn_why))
    return out
