"""Errors of shoal's tools that a person can act on: the ``shoal`` command shows their message,
not a traceback (tools/cli.py); a script calling the library catches them by type."""

from __future__ import annotations


class SessionError(RuntimeError):
    """A Zenoh session cannot be configured or opened; the message says why and what to check."""
