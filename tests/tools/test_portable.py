"""The reference simulator gives the same bits whichever BLAS kernel numpy's OpenBLAS picks.

OpenBLAS chooses its kernel by the CPU (and OPENBLAS_CORETYPE). Until the control code stopped
handing 2- and 3-vectors to BLAS (geometry/vectors.py: ``dot``, ``norm``, ``shaped``), a
container on the same machine, where OPENBLAS_CORETYPE was not set, picked kernel "SkylakeX"
instead of "Haswell", and its run of ``obstacles`` left the reference by 1 ulp at tick 1,114: a
compose run no longer equalled the reference computed on the host. Each variant here runs in
its own process: the kernel is fixed when numpy loads.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

CHILD = """
from shoal.tools.campaign.fields import make_field
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario

base = load_scenario("obstacles")
runs = [load_scenario(name) for name in ("default", "obstacles", "passage")]
runs += [make_field(base, seed, mode) for seed, mode in ((0, "inside"), (1, "A4"), (2, "gap"))]
for s in runs:
    print(s.name, simulate(s).digest())
"""


def _kernels() -> list[str]:
    """OpenBLAS kernels this CPU can run: always the SSE3 one, then AVX2 and AVX-512 ones."""
    flags = set()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("flags"):
                flags = set(line.split(":", 1)[1].split())
                break
    kernels = ["Prescott"]
    if {"avx2", "fma"} <= flags:
        kernels.append("Haswell")
    if {"avx512f", "avx512dq", "avx512bw", "avx512vl"} <= flags:
        kernels.append("SkylakeX")
    return kernels


def _start(kernel: str, baseline_simd: bool) -> subprocess.Popen[str]:
    env = dict(os.environ, OPENBLAS_CORETYPE=kernel, OPENBLAS_VERBOSE="2")
    if baseline_simd:  # numpy's own dispatch, down to its baseline too
        env["NPY_DISABLE_CPU_FEATURES"] = "X86_V3 X86_V4 AVX512_ICL AVX512_SPR"
    return subprocess.Popen(
        [sys.executable, "-c", CHILD],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip


def _result(proc: subprocess.Popen[str]) -> tuple[str, str]:
    try:
        stdout, stderr = proc.communicate(timeout=300)
    finally:
        proc.kill()  # no-op once it has exited
    assert proc.returncode == 0, stderr[-2000:]
    cores = [ln for ln in (stdout + stderr).splitlines() if ln.startswith("Core:")]
    lines = [ln for ln in stdout.splitlines() if not ln.startswith("Core:")]
    return (cores[0] if cores else "?"), "\n".join(lines)


@pytest.mark.skipif(sys.platform != "linux" or os.uname().machine != "x86_64", reason="x86-64")
def test_every_blas_kernel_gives_the_reference_the_same_bits() -> None:
    kernels = _kernels()
    if len(kernels) < 2:
        pytest.skip("this CPU runs only one OpenBLAS kernel")
    # One process per kernel, all at once: each is one core's work for a few seconds.
    procs = {k: _start(k, baseline_simd=(k == "Prescott")) for k in kernels}
    results = {k: _result(proc) for k, proc in procs.items()}
    used = {core for core, _ in results.values()}
    assert len(used) == len(kernels), results  # each variant really ran another kernel
    digests = {out for _, out in results.values()}
    assert len(digests) == 1, results
    assert len(next(iter(digests)).splitlines()) == 6
