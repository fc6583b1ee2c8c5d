"""The progress bar every long command shows: on stderr, and only on a terminal.

stdout stays clean for what a command prints (JSON, file names), and a bar drawn into a pipe or
a CI log would only be noise.
"""

from __future__ import annotations

import sys
from typing import Any

import click


def progress_bar(length: int, label: str, *, show: bool = True) -> Any:
    """A click progress bar of ``length`` steps; hidden unless ``show`` and stderr is a tty."""
    return click.progressbar(
        length=length, label=label, file=sys.stderr, hidden=not (show and sys.stderr.isatty())
    )


def advance_to(bar: Any, done: int, total: int) -> None:
    """Move ``bar`` to ``done`` of ``total``, for work whose size is learnt as it goes."""
    bar.length = total
    bar.update(done - bar.pos)
