"""Checking a lockstep run from its log alone: re-simulate the attached scenario with the
reference simulator and compare every recorded tick, bit for bit. The reference runs the plant
the scenario document records and, for a run with ``--safety-layer reach``, that layer."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from shoal.bus.messages import TickRecord
from shoal.bus.types import Clock, SafetyLayer
from shoal.tools.extras import require
from shoal.tools.log.reader import read_documents, read_ticks, recorded_scenario
from shoal.tools.log.salvage import LogError, check_log
from shoal.tools.simulator import run
from shoal.world.errors import ScenarioError
from shoal.world.plant import KINEMATICS, PlantError


class VerifyError(ValueError):
    """The log cannot be verified (no scenario, no ticks, a realtime run)."""


@dataclass(frozen=True)
class Verdict:
    recorded: int  # tick records in the log
    matching: int
    first_mismatch: int | None  # tick
    scenario: str
    layer: SafetyLayer = SafetyLayer.REFEREE  # the one the reference re-ran the run with

    @property
    def ok(self) -> bool:
        return self.recorded > 0 and self.matching == self.recorded


def verify(path: Path, *, progress: Callable[[int, int], None] | None = None) -> Verdict:
    """``progress(tick, last_tick)`` is called after each re-simulated tick."""
    try:
        check_log(path)
    except LogError as exc:
        raise VerifyError(str(exc)) from None
    docs = read_documents(path)
    if "scenario" not in docs:
        raise VerifyError(f"{path}: no scenario recorded in the log")
    if docs.get("summary", {}).get("clock") == Clock.REALTIME:
        raise VerifyError(
            f"{path}: a realtime run depends on timing, so no re-simulation can match it; "
            "only lockstep runs are verified (`shoal replay` plays this one back)"
        )
    try:
        scenario = recorded_scenario(docs["scenario"])
    except ScenarioError as exc:
        raise VerifyError(f"{path}: the recorded scenario does not load: {exc}") from None
    recorded = {r.tick: r for r in read_ticks(path)}
    if not recorded:
        raise VerifyError(f"{path}: no tick records")
    plant, dynamics = docs["scenario"].get("plant", KINEMATICS), docs["scenario"].get("dynamics")
    if plant != KINEMATICS:
        require("physics", f"verifying a run with --plant {plant}")
    try:
        layer = recorded_layer(docs)
        ticks = run(scenario, str(plant), None if dynamics is None else str(dynamics), layer)
        return replace(_compare(ticks, recorded, scenario.name, progress), layer=layer)
    except (PlantError, ScenarioError) as exc:
        raise VerifyError(f"{path}: the recorded plant cannot run: {exc}") from None


def recorded_layer(docs: Mapping[str, Mapping[str, Any]]) -> SafetyLayer:
    """The layer the reference re-runs a lockstep run with, from its log's documents: the
    reach layer where the scenario document or the summary names it (``safety_layer``), else
    the referee, which in lockstep changes nothing. The world records it in the summary only:
    a reach run's log cut short before its summary is re-run with the referee, and differs."""
    named = docs.get("scenario", {}).get("safety_layer") or docs.get("summary", {}).get(
        "safety_layer"
    )
    return SafetyLayer.REACH if named == SafetyLayer.REACH else SafetyLayer.REFEREE


def _compare(
    ticks: Iterator[TickRecord],
    recorded: dict[int, TickRecord],
    name: str,
    progress: Callable[[int, int], None] | None,
) -> Verdict:
    last = max(recorded)
    matching, first_bad = 0, None
    for t in ticks:
        if t.tick > last:
            break
        r = recorded.get(t.tick)
        # Every field but who was alive: the reference has no processes to lose.
        same = r is not None and replace(t, alive=r.alive) == r
        if same:
            matching += 1
        elif r is not None and first_bad is None:
            first_bad = t.tick
        if progress is not None:
            progress(t.tick, last)
    return Verdict(len(recorded), matching, first_bad, name)
