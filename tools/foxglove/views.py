"""Views of a run for people, in Foxglove: a pure function from a run's records to messages.

In: the scenario (obstacles, graph, formation, dt) and the tick records and events, each with the
log time the logger gave it. Out: :class:`View` messages in log-time order, on fixed topics that
do not name the run, so a Foxglove layout made for one run fits every run. Reading and writing
MCAP files is tools/foxglove/export.py; this module does no I/O but reading its schema files.

**Time.** A view's MCAP log time, and the ``timestamp`` inside it, is the log time of the record
it shows (the logger's wall clock, ns since the epoch): the views share the raw channels'
timeline, so Foxglove's playback, a view and the raw message it came from all line up, in
lockstep and realtime runs alike. Simulated time is a field (``t`` = tick·dt, s) of the scalar
channels; decimation is counted in ticks, i.e. in simulated time.

Channels (docs/foxglove.md has the list with meanings and units): the scene layers of
tools/foxglove/scene.py, agent frames, a log, and the scalar channels of tools/foxglove/plots.py.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources

import numpy as np

from shoal.bus.messages import Event, PlantRecord, TickRecord
from shoal.geometry.vectors import FloatArray
from shoal.tools.foxglove.msgs import Json, log, vec3s
from shoal.tools.foxglove.plots import PLANT, TRACKING, plant_message, plots, tracking
from shoal.tools.foxglove.plots import SCHEMAS as PLOT_SCHEMAS
from shoal.tools.foxglove.plots import TOPICS as PLOT_TOPICS
from shoal.tools.foxglove.scene import Layers
from shoal.world.scenario import Scenario

WORLD = "/shoal/scene/world"
SENSING = "/shoal/scene/sensing"
AGENTS = "/shoal/scene/agents"
GRAPH = "/shoal/scene/graph"
TRAILS = "/shoal/scene/trails"
FRAMES = "/shoal/tf"
LOG = "/shoal/log"
STATIC = (WORLD, SENSING)  # the layers drawn once (a viewer who subscribes late needs them again)
MOVING = (FRAMES, AGENTS, GRAPH)  # the scene's layers that move with every tick

SCENE = "foxglove.SceneUpdate"
TOPICS: dict[str, str] = {  # topic → schema name, in the order the channels are registered
    WORLD: SCENE,
    SENSING: SCENE,
    AGENTS: SCENE,
    GRAPH: SCENE,
    TRAILS: SCENE,
    FRAMES: "foxglove.FrameTransforms",
    LOG: "foxglove.Log",
    **PLOT_TOPICS,
    TRACKING: "shoal.Tracking",
}
PHYSICS_TOPICS = {PLANT: "shoal.Plant"}  # only in the exported views of a physics run
SCHEMAS_VERSION = "2.1.0"  # of npm @foxglove/schemas, that tools/foxglove/schemas/ holds
BLOCK = 512  # ticks whose metrics are computed at once: bounded memory for any run length


@dataclass(frozen=True)
class RunLog:
    """What the views are made from. ``ticks`` are (log time ns, record) in tick order;
    ``events`` are (log time ns, event) in log-time order; ``start_ns`` is the log time of the
    scenario document, which stamps the layers drawn once."""

    scenario: Scenario
    start_ns: int
    ticks: Sequence[tuple[int, TickRecord]]
    events: Sequence[tuple[int, Event]] = ()
    plants: Mapping[int, PlantRecord] = field(default_factory=dict)  # tick → a physics plant's


@dataclass(frozen=True)
class ViewOptions:
    """Rates in simulated time. The scene moves at ``scene_hz``; the trails (whose messages
    grow with the run) are redrawn at ``trail_hz`` from points ``trail_spacing_s`` apart, at
    most ``trail_points`` per agent; the scalar channels are written at ``plot_hz`` (every tick
    when dt ≥ 1/plot_hz)."""

    scene_hz: float = 20.0
    trail_hz: float = 4.0
    trail_spacing_s: float = 0.25
    trail_points: int = 2000
    plot_hz: float = 100.0


@dataclass(frozen=True, slots=True)
class View:
    topic: str
    ns: int  # MCAP log time (= publish time), and the message's timestamp
    message: Json


def schema_text(name: str) -> bytes:
    """The schema data of a channel: Foxglove's published JSON schema for ``foxglove.*``
    (shipped in tools/foxglove/schemas/), shoal's own for the scalar channels."""
    if name.startswith("foxglove."):
        files = resources.files("shoal.tools.foxglove.schemas")
        return files.joinpath(f"{name.removeprefix('foxglove.')}.json").read_bytes()
    return json.dumps(PLOT_SCHEMAS[name], indent=1, ensure_ascii=False).encode()


def every(hz: float, dt: float) -> int:
    """Ticks between two messages at ``hz`` Hz of simulated time (at least 1)."""
    return max(1, round(1.0 / (hz * dt)))


def views(
    run: RunLog,
    options: ViewOptions = ViewOptions(),
    progress: Callable[[int], None] | None = None,
) -> Iterator[View]:
    """Every view message of ``run``, in log-time order. ``progress(k)`` is called after the
    k-th tick record (0-based) has been turned into views."""
    s = run.scenario
    scene = _Scene(s, options)
    plot = every(options.plot_hz, s.dt)
    events = list(run.events)[::-1]  # popped from the end, earliest first
    yield View(WORLD, run.start_ns, scene.layers.world(run.start_ns))
    prev: TickRecord | None = None
    last = len(run.ticks) - 1
    for start in range(0, len(run.ticks), BLOCK):
        block = run.ticks[start : start + BLOCK]
        records = [r for _ns, r in block]
        metrics = plots(s, records)
        following = run.ticks[start + BLOCK][1] if start + BLOCK < len(run.ticks) else None
        tracked = tracking(s, records, None if following is None else following.positions)
        for j, (ns, r) in enumerate(block):
            while events and events[-1][0] <= ns:
                yield event_view(*events.pop())
            final = start + j == last
            yield from scene.at(ns, r, first=prev is None, final=final)
            if r.tick % plot == 0 or final:
                for topic, message in metrics[j].items():
                    yield View(topic, ns, message)
                yield View(TRACKING, ns, tracked[j])
                if (moved := run.plants.get(r.tick)) is not None:
                    yield View(PLANT, ns, plant_message(s, moved))
            for level, name, text in changes_between(s, prev, r):
                yield View(LOG, ns, log(ns, level, text, name))
            prev = r
            if progress is not None:
                progress(start + j)
    while events:
        yield event_view(*events.pop())


class _Scene:
    """The moving layers, tick by tick: what to draw at which tick, and the state that spans
    ticks (the trails' points, the last drawn positions for the agents' velocity arrows)."""

    def __init__(self, scenario: Scenario, options: ViewOptions) -> None:
        self.layers = Layers(scenario)
        self.dt = scenario.dt
        self.every = every(options.scene_hz, self.dt)
        self.trail_every = every(options.trail_hz, self.dt)
        self.spacing = every(1.0 / options.trail_spacing_s, self.dt)
        self.keep = options.trail_points
        # Agents, then moving obstacles (scene.py's trails).
        self.history: list[list[Json]] = [[] for _ in range(scenario.n + len(scenario.mover_ids))]
        self.drawn: tuple[int, FloatArray] | None = None  # tick and positions last drawn

    def at(self, ns: int, r: TickRecord, *, first: bool, final: bool) -> Iterator[View]:
        sample = r.tick % self.spacing == 0
        draw = r.tick % self.every == 0 or first or final
        redraw = r.tick % self.trail_every == 0 or final
        if not (sample or draw or redraw):
            return
        where = vec3s(r.positions)  # shared by every layer of this tick
        tracked = [*where, *vec3s(r.mover_centres)] if r.mover_centres else where
        if sample:
            for h, p in zip(self.history, tracked, strict=True):
                h.append(p)
                del h[: -self.keep]
        if draw:
            yield View(FRAMES, ns, self.layers.frames(ns, where, r.headings))
            if first:  # locked to the agents' frames: drawn once, once the frames exist
                yield View(SENSING, ns, self.layers.sensing(ns))
            yield View(AGENTS, ns, self.layers.agents(ns, r, where, self._velocities(r)))
            yield View(GRAPH, ns, self.layers.graph(ns, r, where))
        if redraw:
            yield View(TRAILS, ns, self.layers.trails(ns, self.history, r, tracked))

    def _velocities(self, r: TickRecord) -> list[list[float]]:
        """Each agent's velocity averaged since the previous drawing: the commanded velocity of
        one tick chatters (the sign term), which an arrow redrawn at 20 Hz would show as noise."""
        here = np.asarray(r.positions, dtype=np.float64)
        if self.drawn is None:
            moved = np.asarray(r.velocities, dtype=np.float64)
        else:
            moved = (here - self.drawn[1]) / ((r.tick - self.drawn[0]) * self.dt)
        self.drawn = (r.tick, here)
        return [list(v) for v in moved.tolist()]


def event_view(ns: int, e: Event) -> View:
    """A world event as a foxglove.Log line (a level outside Foxglove's 0–5 becomes 0,
    UNKNOWN: the wire does not bound it)."""
    name = f"agent {e.agent}" if e.agent else "world"
    level = e.level if 0 <= e.level <= 5 else 0
    return View(LOG, ns, log(ns, level, f"tick {e.tick}: {e.text}", name))


def changes_between(
    s: Scenario, prev: TickRecord | None, r: TickRecord
) -> Iterator[tuple[int, str, str]]:
    """Log lines (level, name, text) derived from the records: an agent starts or stops evading,
    the largest σ applied changes. (Departures are the world's own events.)"""
    t = f"tick {r.tick} (t = {r.tick * s.dt:.2f} s)"
    for i, w in enumerate(r.omega):
        if w != (prev.omega[i] if prev is not None else False):
            what = (
                "starts evading an obstacle (Ω = 1); its neighbours drop it"
                if w
                else "stops evading (Ω = 0)"
            )
            yield 2, f"agent {i + 1}", f"{t}: agent {i + 1} {what}"
    before = max(prev.sigma) if prev is not None else 1.0
    if max(r.sigma) != before:
        yield 2, "formation", f"{t}: largest σ applied {before:g} → {max(r.sigma):g}"
