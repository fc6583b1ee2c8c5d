"""The physics plant's cost (``shoal bench --physics``): CPU per simulated second of MuJoCo moving
n robots (world/physics/), beside the world's own kinematics moving the same robots on the same
commands — the floor, measured in the same run.

For each size and drive, a reference run on the kinematic plant records every tick's commands;
both plants are then driven through those commands alone (no controller), each timed by its
process's CPU clock. A whole reference run on the engine (the controllers, the referee and the
engine, one process) gives the real-time factor a user sees: simulated seconds per CPU second.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from shoal.tools.bench.formations import bench_scenario
from shoal.tools.bench.table import legend, table
from shoal.tools.simulator import simulate
from shoal.world.loader import scenario_from_dict
from shoal.world.plant import KINEMATICS, MUJOCO, Plant, simulated
from shoal.world.scenario import Scenario

SIZES = (5, 20, 50)
SECONDS = 4.0  # simulated seconds per measurement
PRESETS = {"holonomic": "holonomic", "differential": "gritsbot"}


def _scenario(n: int, drive: str, seconds: float) -> Scenario:
    data = bench_scenario(n, round(seconds / 0.01))
    if drive == "differential":  # GRITSbot-sized unicycles, the wedge scaled down to them
        data["agents"] = [{"offset": [0.15 * x for x in a["offset"]]} for a in data["agents"]]
        data["leader"] = {"waypoints": [[0, 0], [100, 0]], "speed": 0.04}
        data["agent_radius"] = 0.05
        data["control"] = {"alpha": 1.0, "beta": 0.06, "sensing_radius": 0.8,
                           "trigger_radius": 0.6, "epsilon": 0.02,
                           "safety_margin": 0.12}  # fmt: skip
        data["initial_noise"] = 0.02
        data["kinematics"] = {"model": "unicycle", "lookahead": 0.05, "max_speed": 0.2,
                              "max_turn_rate": 3.6, "wheel_radius": 0.016, "axle": 0.11,
                              "max_wheel_speed": 12.5}  # fmt: skip
    return scenario_from_dict(data)


def _drive_plant(plant: Plant, commands: np.ndarray) -> float:
    """CPU seconds to move ``plant`` through every tick's ``commands`` (T, n, dim)."""
    start = time.process_time()
    for velocities in commands:
        seen = plant.observe()
        plant.send(velocities, seen.headings)
    return time.process_time() - start


def bench_physics(
    sizes: tuple[int, ...] = SIZES, seconds: float = SECONDS, say: Callable[[str], None] = print
) -> dict[str, Any]:
    rows = []
    for drive, preset in PRESETS.items():
        for n in sizes:
            say(f"physics plant: {n} {drive} robots ({preset}), {seconds:g} simulated s")
            scn = _scenario(n, drive, seconds)
            commands = simulate(scn).velocities
            kinematic = _drive_plant(simulated(scn, KINEMATICS), commands)
            engine = _drive_plant(simulated(scn, MUJOCO, preset), commands)
            start = time.process_time()
            simulate(scn, plant=MUJOCO, dynamics=preset)
            whole = time.process_time() - start
            simulated_s = commands.shape[0] * scn.dt
            rows.append({
                "robots": n, "drive": drive, "preset": preset,
                "engine_cpu_ms_per_s": 1000 * engine / simulated_s,
                "kinematics_cpu_ms_per_s": 1000 * kinematic / simulated_s,
                "engine_over_kinematics": engine / kinematic,
                "run_x_realtime": simulated_s / whole,
            })  # fmt: skip
    return {"physics": rows, "seconds": seconds}


COLUMNS = (
    ("engine ms/s", "CPU ms per simulated second of MuJoCo moving the robots, 1 ms physics "
     "steps, its motors' loops and its judgement of every step"),
    ("kinematics ms/s", "the floor: the world's own kinematics on the same commands"),
    ("ratio", "engine over kinematics"),
    ("run × realtime", "a whole reference run on the engine (controllers, referee, engine, one "
     "process): simulated seconds per CPU second; the target is ≥ 5 at 5 robots"),
)  # fmt: skip


def render_physics(result: dict[str, Any]) -> str:
    rows = [
        (f"{r['robots']} {r['drive']} ({r['preset']})", r["engine_cpu_ms_per_s"],
         r["kinematics_cpu_ms_per_s"], f"{r['engine_over_kinematics']:.1f}×",
         f"{r['run_x_realtime']:.1f}")
        for r in result["physics"]
    ]  # fmt: skip
    headers = ("robots", *(name for name, _ in COLUMNS))
    title = f"the physics plant, {result['seconds']:g} simulated s per row (CPU, one core)"
    return "\n".join([title, *table(headers, rows), *legend(COLUMNS)])
