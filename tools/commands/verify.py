"""``shoal verify``: re-simulate a lockstep run from its log and compare every tick."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from shoal.bus.types import SafetyLayer
from shoal.tools.commands.logs import log_files, run_logs
from shoal.tools.progress import advance_to, progress_bar
from shoal.tools.verify import VerifyError
from shoal.tools.verify import verify as check


@click.command()
@log_files
def verify(files: tuple[Path, ...]) -> None:
    """Re-simulate the scenario recorded in each FILE (a lockstep run's log) and check every
    recorded tick against it. A glob works (Foxglove views files are left out); with no FILE,
    the last run in runs/.

    Exit code 0 only if every recorded tick of every FILE matches bit for bit.
    """
    failed = 0
    for file in run_logs(files, command="verify"):
        with progress_bar(1, f"verifying {file.name}") as bar:
            try:
                verdict = check(file, progress=lambda k, last: advance_to(bar, k + 1, last + 1))
            except VerifyError as exc:
                raise click.ClickException(str(exc)) from None
        click.echo(
            f"{file}: {verdict.scenario}, {verdict.matching} of {verdict.recorded} recorded "
            f"ticks match the reference simulator"
            + (f" (with the {verdict.layer} layer)" if verdict.layer != SafetyLayer.REFEREE else "")
            + ("" if verdict.ok else f"; first mismatch at tick {verdict.first_mismatch}")
        )
        failed += not verdict.ok
    if failed:
        sys.exit(1)
