"""Errors of shoal's tools that a person can act on: the ``shoal`` command shows their message,
not a traceback (tools/cli.py); a script calling the library catches them by type."""

from __future__ import annotations


class SessionError(RuntimeError):
    """A Zenoh session cannot be configured or opened; the message says why and what to check."""


class ExtraMissing(ImportError):
    """An optional extra (pyproject.toml) that a command needs is not installed."""

    def __init__(self, extra: str, needed_by: str, reason: str) -> None:
        super().__init__(
            f"{needed_by} needs the {extra} extra ({reason}): pip install 'shoal[{extra}]'"
        )
        self.extra = extra
