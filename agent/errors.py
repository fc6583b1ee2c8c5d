"""Errors raised by the agent package."""

from __future__ import annotations


class AgentError(Exception):
    """Base of every error the agent package raises."""


class ConfigError(AgentError, ValueError):
    """An agent configuration that the control laws cannot run with."""

    def __init__(self, field: str, problem: str) -> None:
        self.field = field
        self.problem = problem
        super().__init__(f"agent config {field}: {problem}")
