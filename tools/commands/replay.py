"""``shoal replay``: play a run's log again, onto Zenoh with its original keys and timing, or to
Foxglove as a live view (``--live``), or both."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import click

from shoal.bus.runtime import exit_on_signals, warn
from shoal.tools.commands.logs import one_log, the_log
from shoal.tools.commands.options import live_options, live_view
from shoal.tools.foxglove.export import ExportError, read_source, run_log
from shoal.tools.log.replay import Selection
from shoal.tools.log.replay import replay as play
from shoal.tools.log.salvage import LogError, check_log
from shoal.tools.procs.session import PROMPT_CONNECT_MS, client_config, open_session
from shoal.tools.progress import progress_bar


@click.command()
@one_log
@click.option("-r", "--rate", type=click.FloatRange(min=0.001, min_open=False), default=1.0,
              help="Playback speed factor.")  # fmt: skip
@click.option("-l", "--loop", is_flag=True, help="Play again and again until interrupted.")
@click.option("--start-offset", type=click.FloatRange(min=0.0), default=0.0,
              help="Seconds into the log to start from.")  # fmt: skip
@click.option("--topics", default="", help="Only these topics (Zenoh keys), comma-separated.")
@click.option("-e", "--regex", default=None, help="Only topics matching this regex.")
@click.option("-x", "--exclude-regex", default=None, help="Skip topics matching this regex.")
@click.option("--connect", multiple=True,
              help="Zenoh router endpoint to republish onto (needed unless --live).")  # fmt: skip
@live_options("as it replays (the replay waits for a viewer to subscribe)")
def replay(
    file: Path | None,
    rate: float,
    loop: bool,
    start_offset: float,
    topics: str,
    regex: str | None,
    exclude_regex: str | None,
    connect: tuple[str, ...],
    live: bool,
    live_port: int,
) -> None:
    """Play FILE again: its raw channels on their original Zenoh keys (--connect), its
    Foxglove views on a live server (--live), or both, in order, at their original pace (times
    RATE). With no FILE, the last run in runs/."""
    exit_on_signals()
    file = the_log(file, command="replay")
    if not connect and not live:
        raise click.UsageError(
            "say where to: --connect EP (a Zenoh router to republish onto), --live (watch it "
            "in Foxglove), or both"
        )
    try:
        check_log(file)  # before connecting: a bad file is said at once, router or not
    except LogError as exc:
        raise click.ClickException(str(exc)) from None
    selection = Selection(
        tuple(t for t in topics.split(",") if t), regex or None, exclude_regex or None
    )
    with contextlib.ExitStack() as stack:
        view = None
        if live:
            try:  # the recorded scenario, as the export reads it
                src = read_source(file)
                scenario = run_log(file, src).scenario
            except ExportError as exc:
                raise click.ClickException(f"--live: {exc}") from None
            view = stack.enter_context(live_view(scenario, src.run, live_port, source=file.name))
        session = None
        if connect:
            conf = client_config(connect, connect_ms=PROMPT_CONNECT_MS)
            session = stack.enter_context(open_session(conf, "replay"))  # the router is up
        if view is not None:
            warn("replay: waiting for a viewer to subscribe (Ctrl-C to stop)")
            view.wait_for_viewer()
        while True:
            label = f"replaying {file.name}"
            with progress_bar(1000, label) as bar:
                sent = play(
                    session,
                    file,
                    rate=rate,
                    start_offset=start_offset,
                    selection=selection,
                    sink=view,
                    progress=lambda d, t: _advance(bar, d, t),
                )
            click.echo(f"{sent} messages replayed", err=True)
            if not loop or sent == 0:
                break


def _advance(bar: Any, done: float, total: float) -> None:
    bar.update(int(1000 * done / total) - bar.pos if total > 0 else 0)
