"""Build hook: compile shoal's per-tick modules with mypyc where this machine can
(docs/performance.md, "Compiled").

Everything else about the package is in pyproject.toml. The modules in ``COMPILED`` run for every
agent every tick: the controller, the safety filter, the small-vector arithmetic, a unicycle's
step over its arc, the run's tick (world/step.py) and the reference simulator's loop that
drives it in a campaign. mypyc
compiles them, and the messages they pass each other (bus/messages.py), from the same
type-annotated Python into C extensions; the Python stays beside them in the package and is
what runs wherever they are missing. Either gives the same bits:

- every compiled operation is the interpreter's own (IEEE-754 double +, −, ×, ÷, sqrt, libm's
  sin/cos/exp), in the same order;
- ``-ffp-contract=off``: the C compiler must not fuse a·b + c into one rounding (GCC does by
  default where the CPU has FMA, e.g. on aarch64), which would leave the interpreter's bits.

The build keeps the pure modules, saying why, for an editable install (``pip install -e``: the
sources run as they are edited; ``SHOAL_COMPILE=1`` compiles anyway), with ``SHOAL_PURE=1``,
without a C compiler or mypyc, or when compiling fails (the extensions are optional).
tests/tools/test_compiled.py runs the built-ins both ways and compares their digests.
"""

from __future__ import annotations

import os
import shutil
import sys
import sysconfig
import tomllib
from pathlib import Path

from setuptools import Extension, setup

ROOT = Path(__file__).resolve().parent
# (folder in the repository, package) as pyproject.toml maps them.
# Where each package's folder is in the checkout: pyproject.toml's package-dir, read from there
# (one place for the mapping), as source folder -> path inside the package tree.
TREE = {
    folder: package.replace(".", "/")
    for package, folder in tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))[
        "tool"
    ]["setuptools"]["package-dir"].items()
}
COMPILED = [
    "shoal/bus/messages.py",
    "shoal/geometry/vectors.py",
    "shoal/geometry/safety.py",
    "shoal/agent/formation.py",
    "shoal/agent/collision.py",
    "shoal/agent/consensus.py",
    "shoal/agent/controller.py",
    "shoal/agent/leader.py",
    "shoal/world/kinematics.py",
    "shoal/world/unicycle.py",
    "shoal/world/step.py",
    "shoal/tools/simulator.py",
]
# The mypyc runtime shared by the compiled modules: an extension inside shoal, never top level.
GROUP = "shoal.compiled"
# The setuptools commands that build extensions; the others (a PEP 517 backend asks for the
# build requirements and the metadata first) run without mypyc's type check.
BUILDS = {"bdist_wheel", "build", "build_ext", "install", "editable_wheel", "develop"}


def _stage() -> Path:
    """A copy of the packages laid out as their module names (pyproject.toml maps folders to
    packages, mypyc names modules by path)."""
    stage = ROOT / "build" / "mypyc-src"
    shutil.rmtree(stage, ignore_errors=True)
    for folder, package in TREE.items():
        shutil.copytree(
            ROOT / folder, stage / package, ignore=shutil.ignore_patterns("__pycache__", "*.so")
        )
    return stage


def _why_pure() -> str | None:
    """Why this build keeps the pure modules, or None to compile."""
    if os.environ.get("SHOAL_PURE", "") not in ("", "0"):
        return "SHOAL_PURE is set"
    if "editable_wheel" in sys.argv and os.environ.get("SHOAL_COMPILE", "") in ("", "0"):
        # An editable install runs the sources as they are edited; a compiled module beside
        # them would keep running the code it was built from. SHOAL_COMPILE=1 compiles anyway.
        return "an editable install (SHOAL_COMPILE=1 compiles it too)"
    if not BUILDS & set(sys.argv):
        return "this step builds no extension"  # egg_info, dist_info: metadata only
    compiler = (sysconfig.get_config_var("CC") or "cc").split()[0]
    if shutil.which(os.environ.get("CC", compiler).split()[0]) is None:
        return f"no C compiler ({compiler})"
    try:
        import mypyc.build  # noqa: F401
    except ImportError:
        return "mypyc is not importable"
    return None


def extensions() -> list[Extension]:
    why = _why_pure()
    if why is not None:
        if BUILDS & set(sys.argv):
            print(f"shoal: building the pure-Python modules: {why}", file=sys.stderr)
        return []
    from mypyc.build import mypycify

    stage = _stage()
    here = os.getcwd()
    os.chdir(stage)  # mypyc writes its C under build/ of the working directory
    try:
        built = mypycify(
            ["--config-file=", "--ignore-missing-imports", *COMPILED],
            # SHOAL_MYPYC_OPT: the C compiler's optimisation, 0-3 (tests build at 0, quicker: the
            # bits are the same at every level, -ffp-contract=off below; test_compiled.py checks).
            opt_level=os.environ.get("SHOAL_MYPYC_OPT", "3"),
            group_name=GROUP,
            target_dir=str(stage / "build"),
        )
    finally:
        os.chdir(here)
    for ext in built:
        ext.optional = True  # no compiler: keep the pure modules (setuptools warns)
        ext.extra_compile_args = [*ext.extra_compile_args, "-ffp-contract=off"]
        ext.sources = [str(stage / src) if not os.path.isabs(src) else src for src in ext.sources]
        ext.include_dirs = [str(stage / d) if not os.path.isabs(d) else d for d in ext.include_dirs]
    return list(built)


setup(ext_modules=extensions())
