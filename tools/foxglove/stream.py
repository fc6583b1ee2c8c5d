"""The export's views (tools/foxglove/views.py) of a run that is still running, record by record.

The messages are the export's: the same builders (tools/foxglove/scene.py's layers, plots.py's
metrics, views.py's log lines), on the same topics with the same schemas, stamped with the log
time of the record they show (here: when the supervisor received it, as the logger does). Only
*when* a layer is drawn differs. The export draws the scene at fixed ticks (20 Hz of simulated
time); a live viewer wants at most a screen's rate of wall-clock time, whatever the run's speed,
so the caller (tools/foxglove/live.py) asks for the scene when it wants one, and gets the latest
record drawn. The metrics keep the export's decimation (every ``plot`` ticks) and, with a
``plot_rate``, thin it to the wall clock too: of the records due in one slot of ``1/plot_rate`` s
of their stamps, only the latest is kept (its messages are the export's of that tick), so a run
at hundreds of ticks a second costs at most ``plot_rate`` messages per second and topic, and a
run slower than that loses none. The records kept are computed in one batch when asked for; the
others are never computed. Nothing here does I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from shoal.bus.messages import Event, TickRecord
from shoal.geometry.vectors import FloatArray
from shoal.tools.foxglove.msgs import Json, log, vec3s
from shoal.tools.foxglove.plots import plots
from shoal.tools.foxglove.scene import Layers
from shoal.tools.foxglove.views import (
    AGENTS,
    FRAMES,
    GRAPH,
    LOG,
    SENSING,
    TRAILS,
    WORLD,
    View,
    ViewOptions,
    changes_between,
    event_view,
    every,
)
from shoal.world.scenario import Scenario


@dataclass
class _Latest:
    ns: int
    record: TickRecord
    where: list[Json]  # vec3s of its positions
    tracked: list[Json]  # agents', then moving obstacles' positions


@dataclass
class Stream:
    """The views of one run, fed one tick record (or event) at a time."""

    scenario: Scenario
    start_ns: int  # stamps the layers drawn once
    options: ViewOptions = field(default_factory=ViewOptions)
    plot_rate: float | None = None  # metrics per second of stamps, at most; None: every due tick
    layers: Layers = field(init=False)
    latest: _Latest | None = field(init=False, default=None)
    drawn: tuple[int, FloatArray] | None = field(init=False, default=None)  # tick, positions
    due: list[tuple[int, TickRecord]] = field(init=False, default_factory=list)  # for metrics
    history: list[list[Json]] = field(init=False)  # trails: agents, then moving obstacles
    spacing: int = field(init=False)  # ticks between two points of a trail
    plot: int = field(init=False)  # ticks between two messages of a scalar channel
    plotted: tuple[int, int] | None = field(init=False, default=None)  # slot, tick last computed

    def __post_init__(self) -> None:
        s = self.scenario
        self.layers = Layers(s)
        self.history = [[] for _ in range(s.n + len(s.mover_ids))]
        self.spacing = every(1.0 / self.options.trail_spacing_s, s.dt)
        self.plot = every(self.options.plot_hz, s.dt)

    def fits(self, r: TickRecord) -> bool:
        """Whether ``r`` is a record of this scenario (a stranger's record on our key is not)."""
        s = self.scenario
        return len(r.positions) == s.n and all(len(p) == s.dim for p in r.positions)

    def take(self, ns: int, r: TickRecord) -> list[View]:
        """Take the next record; returns the log lines it causes (Ω on or off, σ changes)."""
        prev = self.latest.record if self.latest is not None else None
        where = vec3s(r.positions)
        tracked = [*where, *vec3s(r.mover_centres)] if r.mover_centres else where
        if r.tick % self.spacing == 0:
            for h, p in zip(self.history, tracked, strict=True):
                h.append(p)
                del h[: -self.options.trail_points]
        if r.tick % self.plot == 0:
            self._due(ns, r)
        self.latest = _Latest(ns, r, where, tracked)
        changes = changes_between(self.scenario, prev, r)
        return [View(LOG, ns, log(ns, level, text, name)) for level, name, text in changes]

    def event(self, ns: int, e: Event) -> View:
        return event_view(ns, e)

    def static(self) -> list[View]:
        """The layers drawn once: obstacles and path, and the sensing circles (locked to the
        agents' frames)."""
        ns = self.start_ns
        return [View(WORLD, ns, self.layers.world(ns)), View(SENSING, ns, self.layers.sensing(ns))]

    def scene(self) -> list[View]:
        """The latest record's frames, agents and graph (nothing before the first record)."""
        at = self.latest
        if at is None:
            return []
        ns, r = at.ns, at.record
        return [
            View(FRAMES, ns, self.layers.frames(ns, at.where, r.headings)),
            View(AGENTS, ns, self.layers.agents(ns, r, at.where, self._velocities(r))),
            View(GRAPH, ns, self.layers.graph(ns, r, at.where)),
        ]

    def trails(self) -> list[View]:
        at = self.latest
        if at is None:
            return []
        return [View(TRAILS, at.ns, self.layers.trails(at.ns, self.history, at.record, at.tracked))]

    def metrics(self, *, final: bool = False) -> list[View]:
        """The scalar channels of every record due since the last call, in tick order; with
        ``final``, of the latest record too (if not computed yet), as the export writes the
        run's last tick: the one message that may share a slot with an earlier one."""
        at = self.latest
        if final and at is not None:
            pending = self.due[-1][1] if self.due else None
            done = self.plotted is not None and self.plotted[1] == at.record.tick
            if pending is not at.record and not done:
                self._due(at.ns, at.record, final=True)
        due, self.due = self.due, []
        if not due:
            return []
        self.plotted = (self._slot(due[-1][0]), due[-1][1].tick)
        batch = plots(self.scenario, [r for _ns, r in due])
        pairs = zip(due, batch, strict=True)
        return [View(t, ns, m) for (ns, _r), msgs in pairs for t, m in msgs.items()]

    def skip_metrics(self) -> None:
        """Forget the records due: nobody is looking at the plots."""
        self.due.clear()

    def _due(self, ns: int, r: TickRecord, *, final: bool = False) -> None:
        """Keep ``r`` for the metrics: with a ``plot_rate``, as the latest of its slot, unless
        that slot's message has gone out already (``final``: even then)."""
        if self.plot_rate is not None:
            slot = self._slot(ns)
            if self.plotted is not None and slot <= self.plotted[0] and not final:
                return  # this slot's message is out: the next slot has the next one
            if self.due and self._slot(self.due[-1][0]) == slot:
                self.due[-1] = (ns, r)  # a later tick of the same slot replaces the earlier
                return
        self.due.append((ns, r))

    def _slot(self, ns: int) -> int:
        """Which ``1/plot_rate`` s of stamps since ``start_ns`` holds ``ns`` (0 without a rate)."""
        if self.plot_rate is None:
            return 0
        return math.floor((ns - self.start_ns) * self.plot_rate / 1e9)

    def _velocities(self, r: TickRecord) -> list[list[float]]:
        """As the export draws them: each agent's velocity averaged since the previous drawing
        (one tick's command chatters)."""
        here = np.asarray(r.positions, dtype=np.float64)
        if self.drawn is None or self.drawn[0] >= r.tick:
            moved = np.asarray(r.velocities, dtype=np.float64)
        else:
            moved = (here - self.drawn[1]) / ((r.tick - self.drawn[0]) * self.scenario.dt)
        self.drawn = (r.tick, here)
        return [list(v) for v in moved.tolist()]
