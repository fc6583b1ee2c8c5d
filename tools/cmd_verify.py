"""``shoal verify``: re-simulate a lockstep run from its log and compare every tick."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import click

from tools.verify import VerifyError
from tools.verify import verify as check


def _advance(bar: Any, tick: int, last: int) -> None:
    bar.length = last + 1
    bar.update(tick + 1 - bar.pos)


@click.command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
def verify(file: Path) -> None:
    """Re-simulate the scenario recorded in FILE and check every recorded tick against it.

    Exit code 0 only if every recorded tick matches bit for bit.
    """
    with click.progressbar(
        length=1, label="verifying", file=sys.stderr, hidden=not sys.stderr.isatty()
    ) as bar:
        try:
            verdict = check(file, progress=lambda k, last: _advance(bar, k, last))
        except VerifyError as exc:
            raise click.ClickException(str(exc)) from None
    click.echo(
        f"{verdict.scenario}: {verdict.matching} of {verdict.recorded} recorded ticks match "
        f"the reference simulator"
        + ("" if verdict.ok else f"; first mismatch at tick {verdict.first_mismatch}")
    )
    if not verdict.ok:
        sys.exit(1)
