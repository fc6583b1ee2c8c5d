"""Errors raised by the agent package."""

from __future__ import annotations


class AgentError(Exception):
    """Base of every error the agent package raises."""
