"""Random obstacle fields around a base scenario, inside or just outside the paper's assumptions.

The safety campaign (``shoal campaign``, docs/campaign.md) needs many fields that the guarantee
covers, and fields that each break one assumption, to show where the guarantee ends. A field
keeps the base's formation, graph, gains and path shape, cuts the leader's path to a short
length (so a thousand fields run in minutes) and places random circles on or near the agents'
desired tracks, where obstacles matter.

Every field is written as scenario YAML first and then loaded from that text, so the saved file
*is* the field: ``shoal simulate FILE`` (or ``shoal campaign --rerun FILE`` for a field the
loader refuses on purpose) reproduces it bit for bit. The judge of "inside" is the loader itself
(:func:`shoal.world.assumptions.check_assumptions`); nothing here re-implements a check. Sampling is
by rejection with a bounded number of tries per obstacle, and fails with :class:`FieldError`.

Modes: ``inside`` satisfies every load-time check. Each other mode breaks one thing (see
:data:`BREACHES`); the static ones are verified with :func:`breaches`, which runs each check of
world/assumptions.py on its own.
"""

from __future__ import annotations

import dataclasses
import enum
import itertools
import math
import warnings
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml

from shoal.agent.consensus import passage_bid
from shoal.bus.types import PathSpec, SafetyLayer, Sinusoid, Waypoints
from shoal.geometry.path import path_position, peak_speed
from shoal.geometry.vectors import FloatArray, shaped
from shoal.world import assumptions
from shoal.world.dynamics import of_agents
from shoal.world.errors import ScenarioError, ScenarioWarning, WorldError
from shoal.world.graph import adjacency, reached_from_leader
from shoal.world.loader import parse_scenario, read_obstacles, scenario_from_dict
from shoal.world.plant import KINEMATICS
from shoal.world.scenario import Obstacle, Scenario, Unicycle


@dataclass(frozen=True)
class Breach:
    """One way out of the guarantee. ``static``: visible to the load-time checks."""

    assumption: str
    what: str
    static: bool


BREACHES: dict[str, Breach] = {
    "A2": Breach(
        "Assumption 2",
        "one edge of the graph is removed so that a follower, once it evades and its "
        "neighbours drop it, cuts another agent off from the leader; an obstacle lies on that "
        "follower's track",
        static=True,
    ),
    "A3": Breach(
        "Assumption 3",
        "one obstacle's radius is at least half the smallest desired inter-agent distance",
        static=True,
    ),
    "A4": Breach(
        "Assumption 4",
        "one obstacle lies across the leader's path (with the filter the leader goes round it; "
        "without, it never evades)",
        static=True,
    ),
    "speed": Breach(
        "Theorem 1 (|f| < β)",
        "the leader moves at 1.05-1.5 β on some axis",
        static=True,
    ),
    "reach": Breach(
        "trigger reach (d̄ > r_max + ρ + ε)",
        "the sensing and trigger radii are so small that an agent is inside an obstacle's guard "
        "circle before (11) can fire",
        static=True,
    ),
    "gap": Breach(
        "Algorithm 1 (σ ≤ σ_max)",
        "two posts straddle the leader's path with a gap too narrow for the formation even "
        "contracted by σ_max; nothing checks this at load",
        static=False,
    ),
}
MODES = ("inside", *BREACHES)
# The modes whose fields the loader refuses: saved, they replay with `shoal campaign --rerun`.
REFUSED = frozenset(("A2", "A3", "A4", "reach"))


class FieldError(WorldError):
    """No field of the asked kind could be placed within the bounded number of tries."""


@dataclass(frozen=True)
class FieldOptions:
    """How fields are drawn. Lengths in m, times in s.

    length : metres of the base's leader path kept (waypoints cut there; a sinusoid runs
        length/speed seconds). tail : seconds simulated after the leader stops, for the
        formation to close up again. clear_start : obstacles sit on slots at least this far along
        the path, so no agent starts next to one. count, radius : obstacles per field and their
        radii (uniform); radii are kept below the A3 and trigger-reach limits in inside fields.
    jitter : uniform ± offset (each axis) of an obstacle from the slot it is drawn on.
    spacing : least free distance between two obstacles' edges, m (the paper asks only that
        they do not overlap, 0; a larger spacing keeps encounters apart, see docs/campaign.md).
    sigma_max : replaces the base's σ_max; 1 turns Algorithm 1's contraction off, leaving
        Algorithm 2 alone (the setting of the paper's Corollary 1).
    initial_noise : uniform ± noise of the agents' starts about their slots (per axis).
    tries : candidates drawn per obstacle before giving up with :class:`FieldError`.
    safety : replaces the base's ``control.safety`` ("filter" or "paper": Algorithm 2 alone).
    boundary_layer : K > 0 runs every field with the optional boundary layer φ = K·β·dt,
        sat(e/φ) in place of the paper's sign(e) (docs/campaign.md, Arrival); 0 keeps the base's.
    kinematics : None keeps the base's; "unicycle" makes every agent a unicycle (the base's own
        figures, or :func:`unicycle_for` a base of single integrators), each starting at a
        heading drawn from the field's seed, on a finer tick where the field's speed limit
        asks more than l/dt (:func:`unicycle_ticks`); "single" makes them single integrators.
    position_error : m; every field's ``position_error`` (each robot's estimate off by up to
        it, docs/safety.md, Position error); None keeps the base's.
    speed_limit : m/s; replaces the base's ``control.speed_limit`` (a robot's own cap; the far
        test of each robot's own safety layer has to believe it, docs/safety.md).
    plant : what moves the robots (world/plant.py): ``kinematics``, or ``mujoco``, robots with
        mass; then the field's YAML carries their ``dynamics:`` section (:func:`robots_section`),
        so that ``shoal simulate --plant mujoco FILE`` reruns it.
    dynamics : the robots' preset (world/dynamics.py ``PRESETS``) with ``plant`` mujoco; None:
        the default for the field's agents (gritsbot for unicycles, holonomic otherwise).
    latency : s from a command to the motors acting on it, with ``plant`` mujoco; None: the
        preset's.
    layer : the safety layer the reference runs each field with (``--safety-layer``): the
        referee, or the reach layer (world/reach_layer.py, the referee for robots with mass);
        the field's YAML says it in its "Reproduce:" line, the field drawn does not depend on it.
    """

    length: float = 14.0
    tail: float = 5.0
    clear_start: float = 6.0
    count: tuple[int, int] = (2, 5)
    radius: tuple[float, float] = (0.3, 1.5)
    jitter: float = 1.5
    spacing: float = 0.0
    sigma_max: float | None = None
    initial_noise: float = 1.0
    tries: int = 200
    safety: str | None = None
    boundary_layer: float = 0.0
    kinematics: str | None = None
    speed_limit: float | None = None
    position_error: float | None = None
    plant: str = KINEMATICS
    dynamics: str | None = None
    latency: float | None = None
    layer: SafetyLayer = SafetyLayer.REFEREE


def robots_section(opts: FieldOptions, unicycles: bool) -> dict[str, Any] | None:
    """A field's ``dynamics:`` section for ``opts`` (None for the kinematic plant): the preset
    named, the default for the field's agents (``unicycles`` or single integrators) otherwise,
    and the latency if ``opts`` sets one. Written even where it names the default, so that the
    saved file says which robots ran."""
    if opts.plant == KINEMATICS:
        return None
    name = opts.dynamics or of_agents(None, (unicycles,), 2)[0].preset
    return {"preset": name, **({} if opts.latency is None else {"latency": opts.latency})}


# -- what a field breaks ------------------------------------------------------------------------


def breaches(s: Scenario) -> frozenset[str]:
    """Names of the load-time checks that ``s`` fails, each on its own (check_assumptions
    stops at the first), so that a field can be shown to break exactly one: A1-A4, ``reach``,
    ``overlap``, ``starts``, ``slots`` (slots closer than the separation), ``goals`` (a final
    slot in a guard circle), the movers' checks, and ``speed`` for |f| ≥ β (world/assumptions.py
    CHECKS: one list for the loader and the campaign)."""
    return assumptions.broken_checks(s)


def needed_contraction(s: Scenario, first: int, second: int) -> float:
    """σ the formation would need to pass between obstacles ``first`` and ``second`` with the
    leader heading through their middle (Algorithm 1's bid without the σ_max cap)."""
    centres, radii = s.obstacle_centres[[first, second]], s.obstacle_radii[[first, second]]
    mid = centres.mean(axis=0)
    across = centres[1] - centres[0]
    heading = np.zeros(s.dim)
    heading[:2] = (across[1], -across[0])
    c = s.control
    return passage_bid(
        mid - heading * 10.0,  # well before the gap, heading through it
        heading,
        centres,
        radii,
        formation_radius=s.formation_radius,
        slot_shift=np.zeros(s.dim),
        safety_margin=c.safety_margin,
        epsilon=c.epsilon,
        sigma_max=math.inf,
    )


# -- loading a saved field ----------------------------------------------------------------------


def load_field(text: str) -> Scenario:
    """A field from its YAML, with every check but the obstacle-dependent assumptions.

    For fields that break A2, A3, A4 or the trigger reach on purpose, which the loader refuses:
    the file is validated by the loader, its obstacles each on their own (not against each
    other or the starts: :func:`breaches` tells what the field breaks).
    """
    data = yaml.safe_load(text)
    if not isinstance(data, Mapping):
        raise ScenarioError("scenario", "the file must hold a mapping of fields")
    rest = {k: v for k, v in data.items() if k != "obstacles"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScenarioWarning)
        bare = scenario_from_dict(rest, source=text, default_name="field")
    return dataclasses.replace(bare, obstacles=read_obstacles(data.get("obstacles", []), bare.dim))


# -- drawing a field ----------------------------------------------------------------------------


def make_field(
    base: Scenario, seed: int, mode: str = "inside", options: FieldOptions | None = None
) -> Scenario:
    """The field number ``seed`` of kind ``mode`` around ``base``; the same inputs always give
    the same field. Its ``source`` is the YAML that reproduces it."""
    if mode not in MODES:
        raise ValueError(f"unknown field mode {mode!r} (one of {', '.join(MODES)})")
    opts = options or FieldOptions()
    rng = np.random.default_rng([seed, zlib.crc32(mode.encode())])
    path, moving = _cut_path(base.path, opts.length)
    if mode == "speed":
        path, moving = _faster(path, moving, base.control.beta, rng)
    data = _skeleton(base, path, moving + opts.tail, moving, seed, opts, mode)
    inherent, cut = frozenset({"speed"} if mode == "speed" else ()), 0
    if mode == "A2":
        data["graph"]["edges"], cut = _fragile_graph(base, rng)
        inherent = frozenset({"A2"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScenarioWarning)
        bare = scenario_from_dict(data)
    placer = _Placer(bare, moving, rng, opts, inherent)
    if mode == "A2":
        placer.on_track(cut, frozenset({"A2"}), "an obstacle on the cutting follower's track")
    _MODE_PLACERS.get(mode, _nothing)(placer)
    placer.normal(int(rng.integers(opts.count[0], opts.count[1] + 1)))
    data["obstacles"] = [{"centre": list(o.centre), "radius": o.radius} for o in placer.obstacles]
    if mode == "reach":
        data["control"] = _short_sight(placer.scenario(), rng)
    header = _header(base, seed, mode, opts.plant, opts.layer)
    text = header + yaml.safe_dump(data, sort_keys=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScenarioWarning)
        field = load_field(text) if mode in REFUSED else parse_scenario(text)
    _confirm(field, mode)
    return field


def _confirm(field: Scenario, mode: str) -> None:
    """The field breaks what its mode names and nothing else (a generator bug otherwise)."""
    broken = breaches(field)
    want = {mode} if mode in BREACHES and BREACHES[mode].static else set()
    if broken != want:
        raise FieldError(
            f"{field.name}: breaks {sorted(broken) or 'nothing'}, meant {sorted(want)}"
        )
    if mode == "gap" and needed_contraction(field, 0, 1) <= field.control.sigma_max:
        raise FieldError(f"{field.name}: the gap is passable within σ_max")


def _header(
    base: Scenario,
    seed: int,
    mode: str,
    plant: str = KINEMATICS,
    layer: SafetyLayer = SafetyLayer.REFEREE,
) -> str:
    if mode == "inside":
        what = "inside the paper's assumptions (every load-time check passes)"
    else:
        b = BREACHES[mode]
        what = f"outside: breaks {b.assumption}: {b.what}"
    rerun = "shoal campaign --rerun" if mode in REFUSED else "shoal simulate"
    return (
        f"# A random obstacle field of `shoal campaign` (tools/campaign/fields.py): "
        f"base {base.name!r}, seed {seed}, mode {mode}.\n# {what}.\n"
        f"# Reproduce: {rerun}{plant_option(plant, layer)} THIS_FILE\n"
    )


def plant_option(plant: str, layer: SafetyLayer = SafetyLayer.REFEREE) -> str:
    """What a rerun command needs to run a field on ``plant`` (its robots are in the file)
    through ``layer``."""
    given = "" if plant == KINEMATICS else f" --plant {plant}"
    return given + ("" if layer == SafetyLayer.REFEREE else f" --safety-layer {layer}")


def _cut_path(path: PathSpec, length: float) -> tuple[PathSpec, float]:
    """The first ``length`` m of the path (along its direction for a sinusoid), and the time the
    leader takes over it, s."""
    if isinstance(path, Sinusoid):
        if path.speed <= 0:
            raise FieldError("a standing sinusoid has no length to cut")
        return path, length / path.speed
    points = np.asarray(path.points, dtype=np.float64)
    kept, run = [points[0]], 0.0
    for a, b in itertools.pairwise(points):
        run += float(np.linalg.norm(b - a))
        if run >= length:
            break
        kept.append(b)
    end = path_position(path, length / path.speed)
    if not np.allclose(end, kept[-1]):
        kept.append(end)
    rounded = np.asarray([[round(float(x), 6) for x in p] for p in kept])
    total = float(np.linalg.norm(np.diff(rounded, axis=0), axis=1).sum())
    cut = Waypoints(points=tuple(tuple(float(x) for x in p) for p in rounded), speed=path.speed)
    return cut, total / path.speed


def _faster(
    path: PathSpec, moving: float, beta: float, rng: np.random.Generator
) -> tuple[PathSpec, float]:
    """The same path run faster, so that its peak speed on some axis is 1.05-1.5 β."""
    k = float(rng.uniform(1.05, 1.5)) * beta / float(peak_speed(path).max())
    if isinstance(path, Sinusoid):
        return dataclasses.replace(path, speed=path.speed * k, period=path.period / k), moving / k
    return dataclasses.replace(path, speed=path.speed * k), moving / k


def unicycle_for(base: Scenario, speed: float | None = None) -> Unicycle:
    """Unicycles for a base of single integrators: l = (ρ − agent_radius)/2, leaving the other
    half of the margin to the arc's sagitta (far more than it needs); |v| ≤ 1.5·max(β·√dim,
    ``speed``), so that neither the sign term's chatter, |(β, …, β)|, nor the field's speed limit
    ``speed`` (m/s, if it sets one) meets the robot's own cap; ω ≤ that over l (the point's cap
    is then |v|'s, a little less for the arc)."""
    c = base.control
    lookahead = (c.safety_margin - base.agent_radius) / 2
    top = 1.5 * max(c.beta * math.sqrt(base.dim), 0.0 if speed is None else speed)
    return Unicycle(lookahead=lookahead, max_speed=top, max_turn_rate=top / lookahead)


def unicycle_ticks(dt: float, robot: Unicycle, speed: float | None) -> int:
    """How many ticks a field of unicycles runs for each of its base's ``dt`` s: 1, unless the
    field's speed limit ``speed`` (m/s) is at least l/dt, the most a point l ahead of the axle
    can move in a tick (world/unicycle.py: the exact arc map's range). Then the smallest k with
    ``speed`` < l·k/dt: a robot that drives that fast on so short a lookahead needs a faster
    control loop (crossing's robots, l = 0.05 m at 20 Hz: 1 m/s at most; 3 m/s at 80 Hz)."""
    if speed is None:
        return 1
    return max(1, math.floor(speed * dt / robot.lookahead) + 1)


def makes_unicycles(base: Scenario, opts: FieldOptions) -> bool:
    """Whether the fields ``opts`` draws around ``base`` are unicycles."""
    if opts.kinematics is None:
        return base.unicycle is not None
    return opts.kinematics == "unicycle"


def _robot(base: Scenario, opts: FieldOptions, speed: float | None) -> Unicycle | None:
    """The field's unicycle (None: single integrators): the base's own, or one made for it and
    for the field's speed limit ``speed``."""
    if not makes_unicycles(base, opts):
        return None
    return base.unicycle or unicycle_for(base, speed)


def _speed_limit(base: Scenario, opts: FieldOptions) -> float | None:
    """m/s: the speed limit the field sets (the options', else the base's own), or None."""
    return opts.speed_limit if opts.speed_limit is not None else base.control.speed_limit


def unicycle_fields(base: Scenario, seed: int, robot: Unicycle) -> dict[str, Any]:
    """The ``kinematics`` and ``agents`` entries that make ``base``'s agents ``robot``s, each
    facing a direction drawn for field ``seed``."""
    if base.dim != 2:
        raise FieldError(f"unicycles drive in the plane: {base.name} has dim {base.dim}")
    given = {f.name: getattr(robot, f.name) for f in dataclasses.fields(robot)}
    rng = np.random.default_rng([seed, 31])
    headings = rng.uniform(-math.pi, math.pi, size=base.n)
    return {
        "kinematics": {"model": "unicycle", **{k: v for k, v in given.items() if v is not None}},
        "agents": [
            {"offset": list(a.offset), "heading": float(h)}
            for a, h in zip(base.agents, headings, strict=True)
        ],
    }


def _skeleton(
    base: Scenario,
    path: PathSpec,
    duration: float,
    moving: float,
    seed: int,
    opts: FieldOptions,
    mode: str,
) -> dict[str, Any]:
    """The field's YAML mapping, obstacles still to come."""
    c = base.control
    speed = _speed_limit(base, opts)
    robot = _robot(base, opts, speed)
    robots = robots_section(opts, robot is not None)  # with mass: the plant's, not the law's
    k = 1 if robot is None else unicycle_ticks(base.dt, robot, speed)
    dt = base.dt / k  # exactly base.dt for k = 1
    ticks = math.ceil(duration / dt - 1e-9)
    faster = f", {k} ticks for each of the base's (unicycles: unicycle_ticks)" if k > 1 else ""
    return {
        "name": f"{base.name}-{mode}-{seed}",
        "description": f"campaign field {seed} ({mode}) around {base.name}{faster}",
        "dim": base.dim,
        "seed": seed,
        "dt": dt,
        "duration": round(ticks * dt, 9),
        "agent_radius": base.agent_radius,
        # the convergence tolerance, factor·β·dt, kept in metres on a finer tick
        "tolerance_factor": base.tolerance_factor * k,
        "control": {
            **{f.name: _plain(getattr(c, f.name)) for f in dataclasses.fields(c)},
            **({} if opts.sigma_max is None else {"sigma_max": opts.sigma_max}),
            **({} if opts.safety is None else {"safety": opts.safety}),
            **({} if opts.speed_limit is None else {"speed_limit": opts.speed_limit}),
            **(
                {"boundary_layer": round(opts.boundary_layer * c.beta * dt, 6)}
                if opts.boundary_layer > 0
                else {}
            ),
        },
        "graph": {"directed": base.directed, "edges": [list(e) for e in base.edges]},
        "agents": [{"offset": list(a.offset)} for a in base.agents],
        "initial_noise": min(opts.initial_noise, _noise_room(base)),
        **(
            {"position_error": opts.position_error}
            if opts.position_error is not None
            else ({"position_error": base.position_error} if base.position_error else {})
        ),
        **({} if robot is None else unicycle_fields(base, seed, robot)),
        **({} if robots is None else {"dynamics": robots}),
        "leader": _path_data(path),
        "reshape": [
            {"at": round(r.tick * base.dt, 9), "scale": r.scale, "rotate": r.rotate}
            for r in base.reshapes
            if r.tick * base.dt <= moving
        ],
    }


def _noise_room(base: Scenario) -> float:
    """The largest start noise (± per axis) that cannot bring two agents closer than the
    filter's separation: (least slot spacing − separation) / (2√dim). A tight formation gets
    less noise than the default, so that every field starts valid (rounded down to mm)."""
    d = base.offsets[:, None, :] - base.offsets[None, :, :]
    spacing = float(np.linalg.norm(d, axis=-1)[np.triu_indices(base.n, 1)].min())
    return math.floor(1000 * (spacing - base.separation) / (2 * math.sqrt(base.dim))) / 1000


def _plain(value: Any) -> Any:
    """A value YAML can write: an enum (``control.safety``) as its string."""
    return str(value) if isinstance(value, enum.Enum) else value


def _path_data(path: PathSpec) -> dict[str, Any]:
    if isinstance(path, Waypoints):
        return {"waypoints": [list(p) for p in path.points], "speed": path.speed}
    return {"sinusoid": {k: (list(v) if isinstance(v, tuple) else v)
                         for k, v in dataclasses.asdict(path).items()}}  # fmt: skip


def _short_sight(s: Scenario, rng: np.random.Generator) -> dict[str, float]:
    """Control with d̄ at 50-95 % of the largest guard radius, d the base's distance above it."""
    c = s.control
    guard = float(s.obstacle_radii.max()) + c.safety_margin + c.epsilon
    trigger = round(guard * float(rng.uniform(0.5, 0.95)), 3)
    short = dataclasses.replace(
        c, trigger_radius=trigger, sensing_radius=trigger + c.sensing_radius - c.trigger_radius
    )
    return {f.name: _plain(getattr(short, f.name)) for f in dataclasses.fields(short)}


class _Placer:
    """Draws obstacles one at a time onto a field, each kept only if the field still breaks
    nothing but what is allowed (rejection, ``opts.tries`` candidates per obstacle)."""

    def __init__(
        self,
        bare: Scenario,
        moving: float,
        rng: np.random.Generator,
        opts: FieldOptions,
        inherent: frozenset[str],
    ) -> None:
        self.bare, self.moving, self.rng, self.opts = bare, moving, rng, opts
        self.obstacles: list[Obstacle] = []
        self.plain: list[Obstacle] = []  # those meant to break nothing
        # What the field breaks whatever its obstacles: the leader's speed, the graph (A2).
        self.inherent = inherent
        self.allowed = inherent
        speed = float(np.linalg.norm(path_position(bare.path, 1.0) - path_position(bare.path, 0)))
        self.first = opts.clear_start / max(speed, 1e-9)  # s: no obstacle slot before this
        if self.first >= moving:
            raise FieldError(
                f"{bare.name}: the path ({moving:.3g} s) ends before obstacles may start "
                f"({opts.clear_start} m along it); give a longer length"
            )
        # Radii of inside obstacles stay below the A3 and trigger-reach limits.
        c = bare.control
        self.r_max = min(opts.radius[1], 0.95 * _a3_radius(bare), 0.95 * (
            c.trigger_radius - c.safety_margin - c.epsilon))  # fmt: skip
        self.ends = np.asarray([self.slot(i, moving) for i in range(bare.n)])

    def scenario(self, extra: list[Obstacle] | None = None) -> Scenario:
        return dataclasses.replace(self.bare, obstacles=(*self.obstacles, *(extra or [])))

    def slot(self, agent: int, t: float) -> FloatArray:
        """Where agent ``agent`` (0-based) should be at time t: p(t) + R(θ)δ/σ, with the
        reshape demanded then."""
        scale, theta = 1.0, 0.0
        for r in self.bare.reshapes:
            if r.tick * self.bare.dt <= t:
                scale, theta = r.scale, r.rotate
        offset = np.asarray(self.bare.agents[agent].offset, dtype=np.float64)
        return path_position(self.bare.path, t) + shaped(offset, sigma=scale, theta=theta)

    def when(self) -> float:
        return float(self.rng.uniform(self.first, self.moving))

    def radius(self, low: float | None = None, high: float | None = None) -> float:
        lo = self.opts.radius[0] if low is None else low
        return float(self.rng.uniform(lo, self.r_max if high is None else high))

    def around(self, point: FloatArray, spread: float) -> tuple[float, ...]:
        moved = point + self.rng.uniform(-spread, spread, size=self.bare.dim)
        return tuple(round(float(x), 3) for x in moved)

    def fits(self, candidates: list[Obstacle], allowed: frozenset[str]) -> bool:
        """The field with ``candidates`` added breaks nothing outside ``allowed``, keeps every
        start and every final slot clear, and the candidates overlap nothing."""
        if not breaches(self.scenario(candidates)) <= allowed:
            return False
        c = self.bare.control
        starts = self.bare.initial_positions
        for o, other in itertools.combinations([*self.obstacles, *candidates], 2):
            gap = math.dist(o.centre, other.centre) - o.radius - other.radius
            if gap < self.opts.spacing and (o in candidates or other in candidates):
                return False
        for o in candidates:
            centre = np.asarray(o.centre)
            guard = o.radius + c.safety_margin + c.epsilon
            if np.linalg.norm(self.ends - centre, axis=1).min() <= guard + 1.0:
                return False  # a final slot next to it: the formation could never settle
            if np.linalg.norm(starts - centre, axis=1).min() <= guard + 1.0:
                return False  # an agent starting next to it, before it has a heading
        return True

    def place(self, draw: Callable[[], list[Obstacle]], breach: frozenset[str], what: str) -> None:
        """Add what ``draw`` returns once it fits; ``breach``: what it is meant to break.

        An obstacle meant to break nothing must also break nothing with the other such
        obstacles alone, so that an outside field has exactly one breaking element."""
        allowed = breach | self.allowed
        for _ in range(self.opts.tries):
            candidates = draw()
            if not self.fits(candidates, allowed):
                continue
            if (
                not breach
                and not breaches(
                    dataclasses.replace(self.bare, obstacles=(*self.plain, *candidates))
                )
                <= self.inherent
            ):
                continue
            self.obstacles.extend(candidates)
            if not breach:
                self.plain.extend(candidates)
            self.allowed = allowed
            return
        raise FieldError(
            f"{self.bare.name}: no place for {what} in {self.opts.tries} tries "
            f"({len(self.obstacles)} obstacles placed); try a longer --length or fewer obstacles"
        )

    def normal(self, count: int) -> None:
        """``count`` obstacles within every assumption, each near a random agent's track."""

        def draw() -> list[Obstacle]:
            agent = int(self.rng.integers(self.bare.n))
            centre = self.around(self.slot(agent, self.when()), self.opts.jitter)
            return [Obstacle(centre, round(self.radius(), 3))]

        for k in range(count):
            self.place(draw, frozenset(), f"obstacle {k + 1} of {count}")

    def on_track(self, agent: int, breach: frozenset[str], what: str) -> None:
        """One obstacle of ordinary size on agent ``agent``'s (0-based) track."""

        def draw() -> list[Obstacle]:
            centre = self.around(self.slot(agent, self.when()), 0.3)
            return [Obstacle(centre, round(self.radius(), 3))]

        self.place(draw, breach, what)


def _a3_radius(s: Scenario) -> float:
    """Half the smallest desired inter-agent distance under the demanded scales, m: the radius
    Assumption 3 requires every obstacle to stay below."""
    scale = max([1.0, *(r.scale for r in s.reshapes)])
    offsets = s.offsets
    return min(
        float(np.linalg.norm(offsets[i] - offsets[j])) / scale / 2
        for i, j in itertools.combinations(range(s.n), 2)
    )


def _nothing(_placer: _Placer) -> None:
    return None


def _fragile_graph(s: Scenario, rng: np.random.Generator) -> tuple[list[list[int]], int]:
    """The base graph less one edge (drawn at random among those that will do) such that
    Assumption 1 still holds but some follower, evading, cuts another agent off from the leader
    (Assumption 2 as world/assumptions.py checks it); the edges, and that follower (0-based)."""
    for drop in rng.permutation(len(s.edges)):
        edges = [list(e) for k, e in enumerate(s.edges) if k != drop]
        a = adjacency(s.n, [(i, j) for i, j in edges], directed=s.directed)
        if len(reached_from_leader(a)) < s.n:
            continue  # Assumption 1 broken too
        cutting = [k for k in range(1, s.n) if len(reached_from_leader(a, without=k)) < s.n]
        if cutting:
            return edges, cutting[int(rng.integers(len(cutting)))]
    raise FieldError(f"{s.name}: no single edge removal breaks Assumption 2 alone")


def _a3_big(p: _Placer) -> None:
    limit = _a3_radius(p.bare)

    def draw() -> list[Obstacle]:
        agent = int(p.rng.integers(1, p.bare.n))
        centre = p.around(p.slot(agent, p.when()), 0.5)
        return [Obstacle(centre, round(limit * float(p.rng.uniform(1.02, 1.25)), 3))]

    p.place(draw, frozenset({"A3"}), "an obstacle too large for Assumption 3")


def _a4_across(p: _Placer) -> None:
    def draw() -> list[Obstacle]:
        r = round(p.radius(), 3)
        centre = p.around(path_position(p.bare.path, p.when()), 0.5 * r)
        return [Obstacle(centre, r)]

    p.place(draw, frozenset({"A4"}), "an obstacle across the leader's path")


def _gap_posts(p: _Placer) -> None:
    """Two posts either side of the leader's path, the free width w such that even σ_max leaves
    the formation wider than w - 2(ρ + ε), and the leader still clears each by more than ρ."""
    c = p.bare.control
    too_wide = 2 * p.bare.formation_radius / c.sigma_max + 2 * (c.safety_margin + c.epsilon)
    low = 2 * c.safety_margin + 0.2

    def draw() -> list[Obstacle]:
        t = p.when()
        here = path_position(p.bare.path, t)
        ahead = path_position(p.bare.path, t + 0.1) - here
        side = np.zeros(p.bare.dim)
        side[:2] = (-ahead[1], ahead[0])
        side /= max(float(np.linalg.norm(side)), 1e-12)
        width = float(p.rng.uniform(low, max(low, too_wide - 0.05)))
        posts = []
        for sign in (1.0, -1.0):
            r = round(p.radius(), 3)
            centre = here + sign * side * (width / 2 + r)
            posts.append(Obstacle(tuple(round(float(x), 3) for x in centre), r))
        return posts

    p.place(draw, frozenset(), "a too-narrow gap")


_MODE_PLACERS: dict[str, Callable[[_Placer], None]] = {
    "A3": _a3_big,
    "A4": _a4_across,
    "gap": _gap_posts,
}
