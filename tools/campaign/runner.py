"""The safety campaign: many random fields through the reference simulator, in parallel.

Each field (tools/campaign/fields.py) runs in a worker process with
:func:`shoal.tools.simulator.reference` and is judged by :mod:`shoal.world.metrics`, the same
figures ``shoal simulate`` prints; the campaign only splits collisions by kind and aggregates
per set (inside, and outside by the assumption broken). An inside field that collides falsifies the
guarantee; an outside one is data. On robots with mass (``--plant mujoco``) the engine judges
collisions, clearances and margins along its own motion, as in ``shoal simulate --plant
mujoco``, and the ticks judge the rest. With ``--safety-layer reach`` each field runs through
the reach layer, whose counts join its outcome. The report of a campaign is
tools/campaign/report.py's.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import multiprocessing
import signal
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from shoal.bus.types import SafetyLayer
from shoal.tools.campaign.fields import BREACHES, FieldOptions, make_field, robots_section
from shoal.tools.campaign.hard import HARD_MODES, hard_field
from shoal.tools.simulator import reference
from shoal.world.errors import WorldError
from shoal.world.loader import parse_scenario
from shoal.world.metrics import Summary, Sweep, summarize
from shoal.world.plant import KINEMATICS
from shoal.world.scenario import Scenario
from shoal.world.trajectory import Trajectory


@dataclass(frozen=True)
class Task:
    """One field to run: the base scenario's YAML and name, the field's seed and mode."""

    base: str
    base_name: str
    seed: int
    mode: str
    options: FieldOptions


# The Outcome fields that are the Summary's own figures, under the same names.
AS_SUMMARIZED = (
    "min_interagent_distance", "convergence_time", "convergence_bound", "final_formation_error",
    "tolerance", "sigma", "omega_episodes", "assumption2_violations", "safety",
    "filter_activity", "stalls", "longest_stall", "separation_margin", "arrived",
    "arrival_time", "not_arrived", "leader_shortfall", "slot_distance", "livelocks",
    "longest_livelock", "at_speed_limit",
)  # fmt: skip


@dataclass(frozen=True)
class Outcome:
    """What one field amounted to. Distances in m, times in s. ``error``: the field could not
    be drawn (then every figure is a placeholder); ``source``: its YAML, kept if it collided."""

    mode: str
    seed: int
    name: str
    obstacles: int
    obstacle_collisions: int
    agent_collisions: int
    min_clearance: float
    min_interagent_distance: float
    convergence_time: float | None
    convergence_bound: float
    final_formation_error: float
    tolerance: float
    sigma: float
    a3_contracted: bool
    omega_episodes: int
    assumption2_violations: int
    seconds: float
    error: str | None = None
    source: str = ""
    safety: str = "filter"
    filter_activity: float = 0.0
    at_speed_limit: float = 0.0  # fraction of agent-ticks at the speed limit
    stalls: int = 0
    longest_stall: float = 0.0
    leader_reached: bool = True
    # The theorem's margins, m (inf where there is nothing to measure), and arrival
    # (world/arrival.py): arrived, when (s), and if not, why; livelocks and the longest (s).
    guard_margin: float = math.inf
    separation_margin: float = math.inf
    arrived: bool = True
    arrival_time: float | None = None
    not_arrived: str | None = None
    leader_shortfall: float = 0.0
    slot_distance: float = 0.0
    livelocks: int = 0
    longest_livelock: float = 0.0
    # Robots with mass (world/physics/): the plant, its robots' preset(s), and what the engine
    # judged. Its collisions are not split by kind (``engine_collisions``; then the two counts
    # above are 0); contacts are every onset the engine reported (a person walking into a
    # robot among them); the deepest ≤ 0, m; tracking error: |achieved − commanded| point
    # velocity per agent-tick, m/s, the run's median, 99th percentile and largest (None: none;
    # not nan, which is unequal to itself and would make two equal outcomes differ).
    plant: str = KINEMATICS
    dynamics: str = ""
    engine_collisions: int = 0
    engine_contacts: int = 0
    engine_deepest_contact: float = 0.0
    tracking_error_p50: float | None = None
    tracking_error_p99: float | None = None
    tracking_error_max: float | None = None
    # The layer between the commands and the robots' motion; the reach layer's counts (None
    # under the referee): robot-ticks told to stop, bounds broken; agent-ticks its braking cap
    # slowed; the largest margin a certified step needed, m.
    safety_layer: str = str(SafetyLayer.REFEREE)
    reach_brakes: int | None = None
    reach_slowed: int | None = None
    reach_largest_margin: float | None = None

    @property
    def collisions(self) -> int:
        return self.obstacle_collisions + self.agent_collisions + self.engine_collisions

    @property
    def collided(self) -> bool:
        return self.collisions > 0

    @property
    def lagged(self) -> bool:
        """Safe, but worth a look: it did not arrive, stalled, livelocked, did not settle, or
        its leader fell short."""
        return (
            not self.arrived
            or self.stalls > 0
            or self.livelocks > 0
            or self.final_formation_error > self.tolerance
            or not self.leader_reached
        )

    @property
    def set_name(self) -> str:
        """The set it is reported in: its mode, with ``/paper`` for the unfiltered runs."""
        return self.mode if self.safety == "filter" else f"{self.mode}/paper"


@functools.lru_cache(maxsize=4)
def _base(text: str, name: str) -> Scenario:
    """The base scenario, parsed once per worker process."""
    return parse_scenario(text, default_name=name)


def judge(
    field: Scenario,
    mode: str = "",
    seconds: float = 0.0,
    plant: str = KINEMATICS,
    layer: SafetyLayer = SafetyLayer.REFEREE,
) -> Outcome:
    """Run ``field`` (of set ``mode``) through the reference simulator on ``plant`` (the
    robots its ``dynamics:`` section names) and ``layer``, and measure it; ``seconds`` of CPU
    already spent on it (drawing it) count towards its time."""
    start = time.process_time()
    traj, judged = reference(field, plant=plant, layer=layer)
    swept = Sweep.of(field, traj)
    summary = summarize(field, traj, swept=swept)
    outcome = measure(field, traj, summary, mode, 0.0, swept)
    if "plant" in judged:  # a physics plant's judgement (the kinematic plant gives none)
        outcome = engine_judged(outcome, judged)
        outcome = dataclasses.replace(
            outcome, source=field.source if outcome.collided or outcome.lagged else ""
        )
    if "reach_brakes" in judged:
        outcome = reach_judged(outcome, judged)
    return dataclasses.replace(outcome, seconds=seconds + time.process_time() - start)


def reach_judged(outcome: Outcome, judged: dict[str, Any]) -> Outcome:
    """``outcome`` with the reach layer's counts (world/reach_layer.py ``Reach.report``)."""
    return dataclasses.replace(
        outcome,
        safety_layer=str(judged["safety_layer"]),
        reach_brakes=int(judged["reach_brakes"]),
        reach_slowed=int(judged["reach_slowed"]),
        reach_largest_margin=float(judged["reach_largest_margin"]),
    )


def engine_judged(outcome: Outcome, judged: dict[str, Any]) -> Outcome:
    """``outcome`` with a physics plant's judgement (world/physics/judge.py) in place of the
    ticks' collisions, clearances and margins, as ``shoal simulate --plant mujoco`` reports."""
    least = judged.get("min_clearance")
    guard = judged.get("guard_margin")
    return dataclasses.replace(
        outcome,
        plant=str(judged["plant"]),
        dynamics=str(judged["dynamics"]),
        obstacle_collisions=0,
        agent_collisions=0,
        engine_collisions=int(judged["collisions"]),
        engine_contacts=int(judged["engine_contacts"]),
        engine_deepest_contact=float(judged["engine_deepest_contact"]),
        min_clearance=math.inf if least is None else float(least),
        guard_margin=math.inf if guard is None else float(guard),
        min_interagent_distance=float(
            judged.get("min_interagent_distance", outcome.min_interagent_distance)
        ),
        separation_margin=float(judged.get("separation_margin", outcome.separation_margin)),
        tracking_error_p50=_figure(judged.get("tracking_error_p50")),
        tracking_error_p99=_figure(judged.get("tracking_error_p99")),
        tracking_error_max=_figure(judged.get("tracking_error_max")),
    )


def _figure(value: Any) -> float | None:
    """A judged figure as a float; None where the engine had none to give."""
    return None if value is None else float(value)


def measure(
    field: Scenario,
    traj: Trajectory,
    summary: Summary,
    mode: str = "",
    seconds: float = 0.0,
    swept: Sweep | None = None,
) -> Outcome:
    """The campaign's figures of one run: the summary's, with collisions split by kind;
    ``swept``: the run's :class:`~shoal.world.metrics.Sweep` if the caller has it already."""
    swept = Sweep.of(field, traj) if swept is None else swept
    spacing = min_desired_spacing(field) / summary.sigma
    outcome = Outcome(
        mode=mode,
        seed=field.seed,
        name=field.name,
        obstacles=len(field.obstacles),
        # body_reach: a unicycle's body about its point's chord (world/unicycle.py)
        obstacle_collisions=swept.obstacle_contacts(field.body_reach) + summary.agent_at_fault,
        agent_collisions=swept.agent_contacts(field.body_reach),  # people: by fault, above
        min_clearance=math.inf if summary.min_clearance is None else summary.min_clearance,
        a3_contracted=bool(field.standing_ids) and spacing <= 2 * float(field.obstacle_radii.max()),
        seconds=seconds,
        leader_reached=summary.leader_shortfall <= summary.arrival_tolerance,
        guard_margin=math.inf if summary.guard_margin is None else summary.guard_margin,
        **{name: getattr(summary, name) for name in AS_SUMMARIZED},
    )
    if outcome.collided or outcome.lagged:  # kept to be saved: the field's own YAML
        outcome = dataclasses.replace(outcome, source=field.source)
    return outcome


def min_desired_spacing(s: Scenario) -> float:
    """Smallest desired inter-agent distance ‖δ_i - δ_j‖ at the demanded scale 1, m."""
    d = s.offsets[:, None, :] - s.offsets[None, :, :]
    dist = np.linalg.norm(d, axis=-1)
    return float(dist[np.triu_indices(s.n, 1)].min())


def run_task(task: Task) -> Outcome:
    """Draw and run one field (in a worker process)."""
    start = time.process_time()
    try:
        if task.mode in HARD_MODES:
            k = task.options.boundary_layer
            unicycles = task.options.kinematics == "unicycle"
            robots = robots_section(task.options, unicycles)
            field = hard_field(
                task.seed, HARD_MODES[task.mode], boundary_layer=k, unicycles=unicycles,
                robots=robots, layer=task.options.layer,
            )  # fmt: skip
        else:
            field = make_field(_base(task.base, task.base_name), task.seed, task.mode, task.options)
    except WorldError as exc:
        return _failed(task, str(exc))
    spent = time.process_time() - start
    return judge(field, task.mode, spent, task.options.plant, task.options.layer)


def _failed(task: Task, error: str) -> Outcome:
    return Outcome(
        task.mode, task.seed, "", 0, 0, 0, math.nan, math.nan, None, math.nan, math.nan,
        math.nan, math.nan, False, 0, 0, 0.0, error=error, safety=task.options.safety or "filter",
    )  # fmt: skip


def tasks(
    base: Scenario,
    seed: int,
    fields: int,
    outside: int,
    options: FieldOptions,
    safety: Sequence[str] = ("filter",),
    *,
    hard: bool = False,
) -> list[Task]:
    """``fields`` inside fields with seeds seed, seed+1, …, then ``outside`` fields per
    breach with the same seeds; each once per ``safety`` mode ("filter", "paper"): the same
    field, run with and without the safety filter. ``hard``: instead ``fields`` hard fields
    (tools/campaign/hard.py) with the filter, half in 2-D (one more if odd), half in 3-D, each
    half with seeds seed, seed+1, … (all in 2-D for unicycles, which drive in the plane)."""
    if hard:
        halves = (fields - fields // 2, fields // 2)
        if options.kinematics == "unicycle":
            halves = (fields, 0)
        return [
            Task(base.source, base.name, seed + k, mode, options)
            for mode, half in zip(HARD_MODES, halves, strict=True)
            for k in range(half)
        ]
    out = []
    for mode in ("inside", *(BREACHES if outside else ())):
        count = fields if mode == "inside" else outside
        for k in range(count):
            for s in safety:
                opts = dataclasses.replace(options, safety=s)
                out.append(Task(base.source, base.name, seed + k, mode, opts))
    return out


T = TypeVar("T")
R = TypeVar("R")


def run_campaign(
    todo: Sequence[T],
    jobs: int,
    done: Callable[[R], None] = lambda _o: None,
    work: Callable[[T], R] = run_task,  # type: ignore[assignment]
) -> list[R]:
    """Run ``work`` on every task on ``jobs`` worker processes (in this process if 1); ``done``
    is called as each finishes. Outcomes come back in task order."""
    if jobs <= 1:
        results = []
        for t in todo:
            results.append(work(t))
            done(results[-1])
        return results
    by_index: dict[int, R] = {}
    # multiprocessing's Pool, not concurrent.futures: on Ctrl-C it can be terminated at once,
    # where an executor's shutdown still ran every queued field (6 minutes for 200 fields).
    pool = multiprocessing.get_context("fork").Pool(jobs, initializer=_ignore_interrupts)
    try:
        for k, outcome in pool.imap_unordered(
            functools.partial(_run_indexed, work), enumerate(todo)
        ):
            by_index[k] = outcome
            done(outcome)
    except BaseException:
        pool.terminate()  # Ctrl-C, or a bug: the workers go now, not after the queue
        raise
    finally:
        pool.close()
        pool.join()
    return [by_index[k] for k in range(len(todo))]


def _run_indexed(work: Callable[[T], R], item: tuple[int, T]) -> tuple[int, R]:
    return item[0], work(item[1])


def _ignore_interrupts() -> None:
    """In a worker: Ctrl-C is the parent's to handle (it terminates the pool)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def saved_stem(name: str, safety: str) -> str:
    """The file name (without .yaml) a failing field is saved under."""
    return name if safety == "filter" else f"{name}-paper"


def save_failures(
    outcomes: Iterable[Outcome], directory: Path, which: Callable[[Outcome], bool] | None = None
) -> list[Path]:
    """Write every field that collided (or, given ``which``, every one it picks) as
    ``DIR/<name>.yaml``; its header says how to rerun it."""
    pick = which or (lambda o: o.collided)
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for o in outcomes:
        if o.error is None and o.source and pick(o):
            path = directory / f"{saved_stem(o.name, o.safety)}.yaml"
            path.write_text(o.source, encoding="utf-8")
            written.append(path)
    return written
