"""``shoal plot``'s work: read a run from its MCAP log and save every figure as PNG and SVG."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mcap.exceptions import McapError

from shoal.tools.log.reader import read_documents, read_trajectory, recorded_scenario
from shoal.tools.log.salvage import LogError, check_log
from shoal.world.errors import ScenarioError


class PlotError(ValueError):
    """The log cannot be plotted (no scenario, no ticks, matplotlib missing)."""


FORMATS = ("png", "svg")
FIGURE_COUNT = 6  # tools/plot/figures.py's FIGURES, without importing matplotlib to count them


def load_view(path: Path) -> object:
    """The run recorded in ``path`` as a ``tools.figures.RunView``."""
    from shoal.tools.plot.figures import RunView  # matplotlib is an optional extra; import on use

    try:
        check_log(path)
        docs = read_documents(path)
    except LogError as exc:
        raise PlotError(str(exc)) from None
    except (McapError, OSError) as exc:
        raise PlotError(f"{path}: not a readable MCAP file ({exc})") from None
    if "scenario" not in docs:
        raise PlotError(f"{path}: no scenario recorded in the log")
    try:
        scenario = recorded_scenario(docs["scenario"])
    except ScenarioError as exc:
        raise PlotError(f"{path}: the recorded scenario does not load: {exc}") from None
    try:
        traj = read_trajectory(path, dt=scenario.dt, lookahead=scenario.lookaheads)
    except ValueError as exc:
        raise PlotError(str(exc)) from None
    clock = docs.get("summary", {}).get("clock", "unfinished")
    return RunView(scenario=scenario, traj=traj, label=f"{scenario.name} ({clock})")


def plot(
    path: Path,
    out: Path,
    *,
    only: tuple[str, ...] = (),
    progress: Callable[[str], None] | None = None,
    overwrite: bool = False,
) -> list[Path]:
    """Draw the figures (all, or those named in ``only``) into ``out``, named after the log
    (``runs/x.mcap`` gives ``x-trajectories.png``, …: two runs never share a figure); the files
    written. PlotError, before anything is drawn, if one of them exists, unless ``overwrite``."""
    try:
        from shoal.tools.plot.figures import FIGURES, RunView
    except ImportError as exc:
        raise PlotError(
            f"shoal plot needs matplotlib ({exc}); install it with: pip install 'shoal[plot]'"
        ) from None
    unknown = set(only) - set(FIGURES)
    if unknown:
        raise PlotError(f"unknown figure(s) {sorted(unknown)}; choose from {sorted(FIGURES)}")
    chosen = [name for name in FIGURES if not only or name in only]
    stem = path.name.removesuffix(".mcap")
    targets = {name: [out / f"{stem}-{name}.{fmt}" for fmt in FORMATS] for name in chosen}
    taken = [t for ts in targets.values() for t in ts if t.exists()]
    if taken and not overwrite:
        raise PlotError(f"{taken[0]} exists; pass --force to overwrite it, or --out another folder")
    view = load_view(path)
    assert isinstance(view, RunView)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name in chosen:
        figure = FIGURES[name](view)
        for target in targets[name]:
            figure.savefig(target, dpi=150, bbox_inches="tight")
            written.append(target)
        if progress is not None:
            progress(name)
    return written
