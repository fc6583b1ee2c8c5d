"""Errors raised by the bus package."""

from __future__ import annotations


class BusError(Exception):
    """Base of every error the bus package raises."""


class WireError(BusError, ValueError):
    """Something that cannot go on the wire as asked (a bad run id, an unknown kind)."""


class FieldProblem(ValueError):
    """A value that cannot be used: names the offending ``field`` and what is wrong with it
    (``problem``); a subclass's ``prefix`` says of what."""

    prefix = ""

    def __init__(self, field: str, problem: str) -> None:
        self.field = field
        self.problem = problem
        super().__init__(f"{self.prefix}{field}: {problem}")


class ConfigError(BusError, FieldProblem):
    """An agent configuration that the control laws cannot run with."""

    prefix = "agent config "


class DecodeError(WireError):
    """A message that is not what its key promises: not msgpack, wrong kind or schema version,
    wrong types, non-finite numbers. Receivers count and drop these."""
