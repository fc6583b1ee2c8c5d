"""shoal: safe formation control for swarms of mobile robots, one OS process per robot.

The Python API (docs/api.md): what the ``shoal`` command does, callable from a script or a
notebook. Everything here is a thin door into the subpackages, imported when first called so
that ``import shoal`` stays cheap for the processes of a swarm, which import ``shoal.agent`` and
``shoal.world`` only:

- :func:`load` a scenario (a built-in's name or a YAML file) — a validated ``Scenario``;
- :func:`simulate` it in this process, the exact reference — a ``Trajectory``;
- :func:`summarize` a trajectory — the figures ``shoal simulate`` prints;
- :func:`run` it as a real swarm (a router, a world, a logger, one process per agent) — the
  world's summary, the log written to ``out``;
- :func:`read_log` a run's MCAP file back — its scenario and trajectory;
- :func:`verify` a lockstep log against the reference, tick by tick.

Subpackages: ``shoal.bus`` (wire types, codec, keys, transport), ``shoal.geometry``
(vectors, the leader's path, the safety filter), ``shoal.agent``
(one agent's control laws and process), ``shoal.world`` (scenarios, kinematics, metrics) and
``shoal.tools`` (the reference simulator, the processes, logs, campaigns, the CLI).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from shoal.tools.verify import Verdict
    from shoal.world.metrics import Summary
    from shoal.world.scenario import Scenario
    from shoal.world.trajectory import Trajectory

__all__ = ["Log", "Run", "load", "read_log", "run", "simulate", "summarize", "verify"]


def load(scenario: str | os.PathLike[str]) -> Scenario:
    """The scenario named ``scenario`` (a built-in: ``default``, ``obstacles``, ``passage``,
    ``sinusoid``) or in the YAML file at that path, checked against the paper's assumptions.
    Raises ``shoal.world.errors.ScenarioError`` (naming the field) if it does not load."""
    from shoal.world.loader import load_scenario

    return load_scenario(os.fspath(scenario))


def simulate(scenario: Scenario | str | os.PathLike[str]) -> Trajectory:
    """Run ``scenario`` (or the one :func:`load` gives for a name or path) in this process,
    every agent and the world in lockstep: the trajectory a lockstep swarm reproduces bit for
    bit."""
    from shoal.tools.simulator import simulate as reference

    return reference(_scenario(scenario))


def summarize(scenario: Scenario, trajectory: Trajectory) -> Summary:
    """Collisions, clearances, convergence against Theorem 1's bound, σ, Ω episodes, the
    safety filter's activity: the figures ``shoal simulate`` prints."""
    from shoal.world.metrics import summarize as figures

    return figures(scenario, trajectory)


@dataclass(frozen=True)
class Run:
    """A finished swarm run: the world's ``summary`` (the figures of :func:`summarize`, as
    JSON-ready values), the MCAP log it wrote to (``log``), and its wall time, s."""

    summary: dict[str, Any]
    log: Path
    wall_s: float


def run(
    scenario: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    clock: str = "lockstep",
    overwrite: bool = False,
    start_timeout: float = 60.0,
) -> Run:
    """Run ``scenario`` (a built-in's name or a YAML file) as a real swarm of OS processes over
    a Zenoh router on a free loopback port, recording it to the MCAP file ``out``; ``clock``
    is ``lockstep`` (the reference's result, bit for bit) or ``realtime``. ``out`` is never
    replaced unless ``overwrite``. Raises ``FileExistsError``, or ``RuntimeError`` if a process
    of the swarm fails or one dies during the run."""
    from shoal.bus.types import Clock
    from shoal.tools.procs.launch import RunPlan, fresh_run_id, launch
    from shoal.tools.procs.swarm import ChildFailed

    if clock not in ("lockstep", "realtime"):
        raise ValueError(f"clock: must be lockstep or realtime, got {clock!r}")
    name = os.fspath(scenario)
    loaded = load(name)
    log = Path(out)
    if log.exists() and not overwrite:
        raise FileExistsError(f"{log} exists; pass overwrite=True to replace it")
    log.parent.mkdir(parents=True, exist_ok=True)
    plan = RunPlan(loaded, log, fresh_run_id(), Clock(clock), start_timeout=start_timeout,
                   force=overwrite)  # fmt: skip
    try:
        result = launch(plan)
    except ChildFailed as exc:
        raise RuntimeError(str(exc)) from None
    if result.lost:
        raise RuntimeError(f"agent process(es) died during the run: {', '.join(result.lost)}")
    return Run(summary=result.summary, log=log, wall_s=result.wall_s)


@dataclass(frozen=True)
class Log:
    """A run read back from its MCAP file: the ``scenario`` it ran and the ``trajectory`` the
    world recorded (tick by tick, as :func:`simulate` returns it)."""

    scenario: Scenario
    trajectory: Trajectory


def read_log(path: str | os.PathLike[str]) -> Log:
    """The scenario and trajectory recorded in the MCAP log at ``path``. Raises
    ``shoal.tools.log.salvage.LogError`` for a file that is not a readable shoal log (an
    unfinished one: ``shoal recover`` it first) and ``ValueError`` if it holds no run."""
    from shoal.tools.log.reader import read_documents, read_trajectory
    from shoal.tools.log.salvage import check_log
    from shoal.world.loader import parse_scenario

    log = Path(path)
    check_log(log)
    docs = read_documents(log)
    if "scenario" not in docs:
        raise ValueError(f"{log}: no scenario recorded in the log")
    scenario = parse_scenario(str(docs["scenario"].get("yaml", "")))
    return Log(scenario, read_trajectory(log, dt=scenario.dt, lookahead=scenario.lookahead))


def verify(path: str | os.PathLike[str]) -> Verdict:
    """Re-simulate the lockstep run logged at ``path`` and compare every tick bit for bit;
    ``verify(p).ok`` is True when all match. Raises ``shoal.tools.verify.VerifyError``."""
    from shoal.tools.verify import verify as check

    return check(Path(path))


def _scenario(scenario: Scenario | str | os.PathLike[str]) -> Scenario:
    return load(scenario) if isinstance(scenario, (str, os.PathLike)) else scenario
