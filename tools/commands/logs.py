"""Which run logs a command reads: the files named, a glob's logs, or the last run.

``shoal run`` writes ``runs/<scenario>-<run id>.mcap`` and its Foxglove views beside it as
``….foxglove.mcap``. A glob such as ``runs/crossing-*.mcap`` matches both; the views file is not
a run's log (it has no scenario, no ticks), so a glob's views files are left out with a note, and
a views file named alone gets an error that names its log. With no file at all, a command reads
the newest log in ``runs/``: the last run, one step away.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TypeVar

import click

from shoal.bus.runtime import warn
from shoal.tools.foxglove.export import SUFFIX as VIEWS_SUFFIX

F = TypeVar("F", bound=Callable[..., object])

RUNS = Path("runs")  # where `shoal run` writes its logs, relative to where it is run


def is_views(path: Path) -> bool:
    """Whether ``path`` is named as a run's Foxglove views file (`shoal export`)."""
    return path.name.endswith(VIEWS_SUFFIX)


def log_of(views: Path) -> Path:
    """``runs/x.foxglove.mcap`` → ``runs/x.mcap``: the log the views were made from."""
    return views.with_name(views.name.removesuffix(VIEWS_SUFFIX) + ".mcap")


def last_run(folder: Path = RUNS) -> Path:
    """The newest log in ``folder`` (by modification time; views files are not logs)."""
    logs = [p for p in folder.glob("*.mcap") if p.is_file() and not is_views(p)]
    if not logs:
        raise click.UsageError(
            f"no run logs in {folder}/ to read: name a log, or make one with `shoal run`"
        )
    return max(logs, key=lambda p: (p.stat().st_mtime_ns, p.name))


def run_logs(files: Sequence[Path], *, command: str) -> list[Path]:
    """The logs ``command`` reads for ``files``: the last run if none is named; a views file
    named alone is an error naming its log; views files among several are left out."""
    if not files:
        found = last_run()
        warn(f"{command}: the last run, {found}")
        return [found]
    views = [f for f in files if is_views(f)]
    logs = [f for f in files if not is_views(f)]
    if not logs:
        log = log_of(views[0])
        where = f"its log is {log}" if log.exists() else f"its log, {log}, is not there"
        raise click.BadParameter(
            f"{views[0]} is the Foxglove views file of a run, not the run's log: {where}",
            param_hint="FILE",
        )
    if views:
        warn(f"{command}: left out {len(views)} Foxglove views file(s), not logs: "
             + ", ".join(str(v) for v in views))  # fmt: skip
    return logs


def log_files(func: F) -> F:
    """FILE...: the logs to read (a glob works); none: the last run in runs/."""
    return click.argument(
        "files",
        metavar="[FILE]...",
        nargs=-1,
        type=click.Path(exists=True, dir_okay=False, path_type=Path),
    )(func)


def one_log(func: F) -> F:
    """[FILE]: the log to read; none: the last run in runs/."""
    return click.argument(
        "file",
        metavar="[FILE]",
        required=False,
        type=click.Path(exists=True, dir_okay=False, path_type=Path),
    )(func)


def the_log(file: Path | None, *, command: str) -> Path:
    """The single log ``command`` reads for ``file`` (see :func:`run_logs`)."""
    return run_logs([] if file is None else [file], command=command)[0]
