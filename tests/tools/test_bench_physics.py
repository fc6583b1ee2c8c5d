"""``shoal bench --physics``: the physics plant's CPU per simulated second beside the kinematic
plant's, measured in the same run on the same commands."""

from __future__ import annotations

import pytest

pytest.importorskip("mujoco", reason="the physics extra: pip install 'shoal[physics]'")

from shoal.tools.bench.physics import bench_physics, render_physics


def test_the_physics_benchmark_times_both_plants_on_the_same_commands() -> None:
    result = bench_physics((3,), seconds=0.5, say=lambda _: None)
    rows = result["physics"]
    assert [(r["robots"], r["drive"]) for r in rows] == [(3, "holonomic"), (3, "differential")]
    for r in rows:
        # the engine's 1 ms steps cost far more than one kinematic step per tick: a floor that
        # is not below it would mean the two were not timed on the same work
        assert r["engine_cpu_ms_per_s"] > r["kinematics_cpu_ms_per_s"] > 0
        assert r["engine_over_kinematics"] == pytest.approx(
            r["engine_cpu_ms_per_s"] / r["kinematics_cpu_ms_per_s"]
        )
        assert r["run_x_realtime"] > 0
    text = render_physics(result)
    assert "3 holonomic (holonomic)" in text and "kinematics ms/s" in text
