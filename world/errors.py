"""Errors and warnings raised by the world package."""

from __future__ import annotations


class WorldError(Exception):
    """Base of every error the world package raises."""


class ScenarioError(WorldError, ValueError):
    """A scenario that cannot be run: names the offending field and what is wrong with it."""

    def __init__(self, field: str, problem: str) -> None:
        self.field = field
        self.problem = problem
        super().__init__(f"{field}: {problem}")


class AssumptionError(ScenarioError):
    """A scenario that breaks one of the paper's Assumptions 1-4."""

    def __init__(self, assumption: int, field: str, problem: str) -> None:
        self.assumption = assumption
        super().__init__(field, f"Assumption {assumption} violated: {problem}")


class BetaWarning(UserWarning):
    """The leader moves as fast as β or faster in some coordinate: Theorem 1 does not apply."""
