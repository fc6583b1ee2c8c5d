"""Errors and warnings raised by the world package."""

from __future__ import annotations

from shoal.bus.errors import FieldProblem


class WorldError(Exception):
    """Base of every error the world package raises."""


class ScenarioError(WorldError, FieldProblem):
    """A scenario that cannot be run: names the offending field and what is wrong with it."""


class AssumptionError(ScenarioError):
    """A scenario that breaks one of the paper's Assumptions 1-4."""

    def __init__(self, assumption: int, field: str, problem: str) -> None:
        self.assumption = assumption
        super().__init__(field, f"Assumption {assumption} violated: {problem}")


class ScenarioWarning(UserWarning):
    """A scenario that runs, but outside something the paper or the filter promises."""


class BetaWarning(ScenarioWarning):
    """The leader moves as fast as β or faster in some coordinate: Theorem 1 does not apply."""


class SpeedCapWarning(ScenarioWarning):
    """The speed limit is so low that, scaled down by it, the law's sign term may not close a
    follower's error against the leader's velocity (world/assumptions.py, cap_needed): Theorem
    1's bound does not hold and the formation may never arrive (a unicycle's point cap is the
    usual cause)."""


class DetourWarning(ScenarioWarning):
    """The leader's path crosses an obstacle's guard (Assumption 4 broken): with the safety
    filter the leader goes round it (agent/leader.py) and the run goes ahead."""
