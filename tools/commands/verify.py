"""``shoal verify``: re-simulate a lockstep run from its log and compare every tick."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from shoal.tools.progress import advance_to, progress_bar
from shoal.tools.verify import VerifyError
from shoal.tools.verify import verify as check


@click.command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
def verify(file: Path) -> None:
    """Re-simulate the scenario recorded in FILE and check every recorded tick against it.

    Exit code 0 only if every recorded tick matches bit for bit.
    """
    with progress_bar(1, "verifying") as bar:
        try:
            verdict = check(file, progress=lambda k, last: advance_to(bar, k + 1, last + 1))
        except VerifyError as exc:
            raise click.ClickException(str(exc)) from None
    click.echo(
        f"{verdict.scenario}: {verdict.matching} of {verdict.recorded} recorded ticks match "
        f"the reference simulator"
        + ("" if verdict.ok else f"; first mismatch at tick {verdict.first_mismatch}")
    )
    if not verdict.ok:
        sys.exit(1)
