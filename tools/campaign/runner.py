"""The safety campaign: many random fields through the reference simulator, in parallel.

Each field (tools/campaign/fields.py) runs in a worker process with
:func:`shoal.tools.simulator.simulate` and is judged by :mod:`shoal.world.metrics`, the same figures
``shoal simulate`` prints; the campaign only splits collisions by kind and aggregates per set
(inside, and outside by the assumption broken). An inside field that collides falsifies the
guarantee; an outside one is data.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import multiprocessing
import signal
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from shoal.tools.campaign.fields import BREACHES, REFUSED, FieldOptions, make_field
from shoal.tools.simulator import simulate
from shoal.world.errors import WorldError
from shoal.world.loader import parse_scenario
from shoal.world.metrics import Summary, clearances, onsets, pair_distances, summarize
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
    stalls: int = 0
    longest_stall: float = 0.0
    leader_reached: bool = True

    @property
    def collided(self) -> bool:
        return self.obstacle_collisions + self.agent_collisions > 0

    @property
    def set_name(self) -> str:
        """The set it is reported in: its mode, with ``/paper`` for the unfiltered runs."""
        return self.mode if self.safety == "filter" else f"{self.mode}/paper"


@functools.lru_cache(maxsize=4)
def _base(text: str, name: str) -> Scenario:
    """The base scenario, parsed once per worker process."""
    return parse_scenario(text, default_name=name)


def judge(field: Scenario, mode: str = "", seconds: float = 0.0) -> Outcome:
    """Run ``field`` (of set ``mode``) through the reference simulator and measure it;
    ``seconds`` of CPU already spent on it (drawing it) count towards its time."""
    start = time.process_time()
    traj = simulate(field)
    return measure(field, traj, summarize(field, traj), mode, seconds + time.process_time() - start)


def measure(
    field: Scenario, traj: Trajectory, summary: Summary, mode: str = "", seconds: float = 0.0
) -> Outcome:
    """The campaign's figures of one run: the summary's, with collisions split by kind."""
    clear = clearances(field, traj)[:, :, list(field.standing_ids)]  # people: by fault
    spacing = min_desired_spacing(field) / summary.sigma
    outcome = Outcome(
        mode=mode,
        seed=field.seed,
        name=field.name,
        obstacles=len(field.obstacles),
        obstacle_collisions=onsets(clear < field.agent_radius) + summary.agent_at_fault,
        agent_collisions=onsets(pair_distances(traj) < 2 * field.agent_radius),
        min_clearance=float(clear.min()) if clear.size else math.inf,
        min_interagent_distance=summary.min_interagent_distance,
        convergence_time=summary.convergence_time,
        convergence_bound=summary.convergence_bound,
        final_formation_error=summary.final_formation_error,
        tolerance=summary.tolerance,
        sigma=summary.sigma,
        a3_contracted=bool(field.standing_ids) and spacing <= 2 * float(field.obstacle_radii.max()),
        omega_episodes=summary.omega_episodes,
        assumption2_violations=summary.assumption2_violations,
        seconds=seconds,
        safety=summary.safety,
        filter_activity=summary.filter_activity,
        stalls=summary.stalls,
        longest_stall=summary.longest_stall,
        leader_reached=summary.leader_shortfall <= summary.tolerance,
    )
    if outcome.collided or lagged(outcome):  # kept to be saved: the field's own YAML
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
        field = make_field(_base(task.base, task.base_name), task.seed, task.mode, task.options)
    except WorldError as exc:
        return _failed(task, str(exc))
    return judge(field, task.mode, time.process_time() - start)


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
) -> list[Task]:
    """``fields`` inside fields with seeds seed, seed+1, …, then ``outside`` fields per
    breach with the same seeds; each once per ``safety`` mode ("filter", "paper"): the same
    field, run with and without the safety filter."""
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


# -- the report ---------------------------------------------------------------------------------


def _quantiles(values: Iterable[float]) -> dict[str, float | None]:
    v = np.asarray([x for x in values if math.isfinite(x)])
    if not v.size:
        return {"min": None, "p01": None, "p05": None, "p50": None}
    q = np.quantile(v, [0.01, 0.05, 0.5])
    return {"min": float(v.min()), "p01": float(q[0]), "p05": float(q[1]), "p50": float(q[2])}


def summarize_set(outcomes: Sequence[Outcome]) -> dict[str, Any]:
    """The figures of one set of fields (all inside, or all breaking the same thing)."""
    ran = [o for o in outcomes if o.error is None]
    bounded = [o for o in ran if math.isfinite(o.convergence_bound) and o.convergence_bound > 0]
    ratios = [
        o.convergence_time / o.convergence_bound for o in bounded if o.convergence_time is not None
    ]
    return {
        "fields": len(ran),
        "not_drawn": len(outcomes) - len(ran),
        "collided": sum(o.collided for o in ran),
        "obstacle_collided": sum(o.obstacle_collisions > 0 for o in ran),
        "agent_collided": sum(o.agent_collisions > 0 for o in ran),
        "collisions": sum(o.obstacle_collisions + o.agent_collisions for o in ran),
        "min_clearance": _quantiles(o.min_clearance for o in ran),
        "min_interagent_distance": _quantiles(o.min_interagent_distance for o in ran),
        "converged": sum(o.convergence_time is not None for o in ran),
        "unbounded": len(ran) - len(bounded),  # Theorem 1 gives no bound (|f| ≥ β)
        "converged_within_bound": sum(r <= 1.0 for r in ratios),
        "max_time_over_bound": max(ratios) if ratios else None,
        "settled_at_end": sum(o.final_formation_error <= o.tolerance for o in ran),
        "contracted": sum(o.sigma > 1.0 for o in ran),
        "a3_broken_by_contraction": sum(o.a3_contracted for o in ran),
        "a2_broken_in_run": sum(o.assumption2_violations > 0 for o in ran),
        "omega_episodes": sum(o.omega_episodes for o in ran),
        "filter_activity": float(np.mean([o.filter_activity for o in ran])) if ran else 0.0,
        "stalled_fields": sum(o.stalls > 0 for o in ran),
        "stalls": sum(o.stalls for o in ran),
        "longest_stall": max((o.longest_stall for o in ran), default=0.0),
        "leader_reached": sum(o.leader_reached for o in ran),
        "cpu_s": round(sum(o.seconds for o in ran), 2),
    }


def report(outcomes: Sequence[Outcome], wall: float, jobs: int) -> dict[str, Any]:
    """The campaign as one JSON-able dict: per set, then every field that collided.

    ``wall`` s for the whole campaign on ``jobs`` processes; each set's ``cpu_s`` is the CPU
    time its fields took (drawing, simulating, measuring), which a loaded machine inflates less.
    """
    sets: dict[str, Any] = {}
    for mode, safety in itertools.product(("inside", *BREACHES), ("filter", "paper")):
        name = mode if safety == "filter" else f"{mode}/paper"
        chosen = [o for o in outcomes if o.set_name == name]
        if chosen:
            sets[name] = summarize_set(chosen)
            sets[name]["safety"] = safety
            if mode != "inside":
                b = BREACHES[mode]
                sets[name]["breaks"] = b.assumption
                sets[name]["static"] = b.static
    failures = [
        {"set": o.set_name, "seed": o.seed, "name": o.name, "obstacle_collisions":
         o.obstacle_collisions, "agent_collisions": o.agent_collisions,
         "min_clearance": o.min_clearance, "min_interagent_distance": o.min_interagent_distance,
         "rerun": "campaign --rerun" if o.mode in REFUSED else "simulate", "safety": o.safety}
        for o in outcomes if o.error is None and o.collided
    ]  # fmt: skip
    lagging = [
        {"set": o.set_name, "seed": o.seed, "name": o.name, "stalls": o.stalls,
         "longest_stall": o.longest_stall, "final_formation_error": o.final_formation_error,
         "tolerance": o.tolerance, "settled": o.final_formation_error <= o.tolerance,
         "leader_reached": o.leader_reached, "safety": o.safety}
        for o in outcomes if o.error is None and not o.collided and lagged(o)
    ]  # fmt: skip
    errors = [{"set": o.set_name, "seed": o.seed, "error": o.error} for o in outcomes if o.error]
    return {
        "fields": len(outcomes),
        "jobs": jobs,
        "wall_s": round(wall, 2),
        "fields_per_s": round(len(outcomes) / wall, 2) if wall > 0 else None,
        "cpu_s_per_field": round(sum(o.seconds for o in outcomes) / max(1, len(outcomes)), 3),
        "sets": sets,
        "failures": failures,
        "lagging": lagging,
        "errors": errors,
    }


def lagged(o: Outcome) -> bool:
    """Safe, but worth a look: it stalled, did not settle, or its leader fell short."""
    return o.stalls > 0 or o.final_formation_error > o.tolerance or not o.leader_reached


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


# Lagging fields listed in the text report; --json lists every one.
LAGGING_SHOWN = 20


def _num(value: Any, digits: int = 3) -> str:
    return "—" if value is None else f"{value:.{digits}f}"


def render(rep: dict[str, Any]) -> str:
    """Two tables a person reads: safety, then convergence and what the runs went through."""
    safety = [
        f"{'set':<12} {'fields':>6} {'collided':>8} {'obstacle':>8} {'agent':>5}   "
        f"{'clearance min':>13} {'p01':>7} {'p05':>7} {'p50':>7}   {'separation min':>14}"
    ]
    runs = [
        f"{'set':<12} {'converged':>9} {'≤ bound':>7} {'max t/bound':>11} {'settled':>7}   "
        f"{'σ > 1':>5} {'A3 by σ':>7} {'A2 in run':>9} {'Ω episodes':>10}"
    ]
    liveness = [
        f"{'set':<12} {'filter active':>13} {'stalled':>7} {'stalls':>6} {'longest':>8}   "
        f"{'leader at goal':>14}"
    ]
    for mode, s in rep["sets"].items():
        clr = s["min_clearance"]
        safety.append(
            f"{mode:<12} {s['fields']:>6} {s['collided']:>8} {s['obstacle_collided']:>8} "
            f"{s['agent_collided']:>5}   {_num(clr['min']):>13} {_num(clr['p01']):>7} "
            f"{_num(clr['p05']):>7} {_num(clr['p50']):>7}   "
            f"{_num(s['min_interagent_distance']['min']):>14}"
        )
        runs.append(
            f"{mode:<12} {s['converged']:>9} {s['converged_within_bound']:>7} "
            f"{_num(s['max_time_over_bound']):>11} {s['settled_at_end']:>7}   "
            f"{s['contracted']:>5} {s['a3_broken_by_contraction']:>7} "
            f"{s['a2_broken_in_run']:>9} {s['omega_episodes']:>10}"
        )
        liveness.append(
            f"{mode:<12} {100 * s['filter_activity']:>12.2f}% {s['stalled_fields']:>7} "
            f"{s['stalls']:>6} {s['longest_stall']:>7.2f}s   {s['leader_reached']:>14}"
        )
    lines = [*safety, "", *runs, "", *liveness, ""]
    for mode, s in rep["sets"].items():
        if mode != "inside" and s["safety"] == "filter":
            lines.append(f"{mode:<12} breaks {s['breaks']}: {BREACHES[mode].what}")
    lines.append(
        "settled: back in formation (error ≤ tolerance) at the end of the tail; stalled: fields "
        "where an agent was held by the filter > 0.5 s; /paper: the same fields, filter off"
    )
    lines.append(
        f"{rep['fields']} fields on {rep['jobs']} processes in {rep['wall_s']:.1f} s "
        f"({rep['fields_per_s']} fields/s; {rep['cpu_s_per_field']} CPU s per field)"
    )
    if rep["lagging"]:
        lines.append(
            f"{len(rep['lagging'])} safe fields to look at (--save-lagging DIR keeps them):"
        )
    for g in rep["lagging"][:LAGGING_SHOWN]:
        what = [f"{g['stalls']} stalls, longest {g['longest_stall']:.2f} s"] if g["stalls"] else []
        if not g["settled"]:
            what.append(f"not settled (error {g['final_formation_error']:.3f} m)")
        if not g["leader_reached"]:
            what.append("leader short of its goal")
        lines.append(f"  {g['set']:<12} seed {g['seed']:>6}: {'; '.join(what)}")
    if len(rep["lagging"]) > LAGGING_SHOWN:
        lines.append(f"  … and {len(rep['lagging']) - LAGGING_SHOWN} more (--json lists all)")
    for e in rep["errors"]:
        lines.append(f"not drawn: {e['set']} seed {e['seed']}: {e['error']}")
    return "\n".join(lines)
