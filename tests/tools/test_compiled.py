"""The per-tick modules compiled by mypyc (setup.py) give the interpreter's bits: the built-ins
and a sample of campaign fields, simulated by an installed, compiled shoal, have the digests
this checkout's pure-Python modules give them (docs/performance.md, "Compiled")."""

from __future__ import annotations

import importlib
import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path
from typing import Any

from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario

COMPILED = [
    "shoal.bus.messages",
    "shoal.geometry.vectors",
    "shoal.geometry.safety",
    "shoal.agent.formation",
    "shoal.agent.collision",
    "shoal.agent.consensus",
    "shoal.agent.controller",
    "shoal.agent.leader",
    "shoal.world.kinematics",
    "shoal.world.unicycle",
    "shoal.world.step",
    "shoal.tools.simulator",
]

# Digests of built-ins (standing obstacles, contraction, people, unicycles) and of campaign fields
# (inside, filter on; around obstacles and crossing, and as unicycles) by whichever shoal is
# imported; JSON on stdout.
DIGESTS = """
from shoal.tools.campaign.fields import FieldOptions, make_field
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario
names = ("obstacles", "passage", "crossing", "robotarium")
out = {name: simulate(load_scenario(name)).digest() for name in names}
for base in ("obstacles", "crossing"):
    for seed in (0, 1):
        field = make_field(load_scenario(base), seed, "inside", FieldOptions())
        out[f"{base}/{seed}"] = simulate(field).digest()
# A gap field: drawing it asks passage_bid about numpy arrays (a TypeError once, compiled).
out["obstacles/gap/0"] = simulate(make_field(load_scenario("obstacles"), 0, "gap", FieldOptions())).digest()
wheels = FieldOptions(kinematics="unicycle")  # headings drawn per field: most turn or reverse
out["obstacles/unicycle/0"] = simulate(make_field(load_scenario("obstacles"), 0, "inside", wheels)).digest()
"""  # noqa: E501


def _compiler() -> bool:
    cc = os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc"
    return shutil.which(cc.split()[0]) is not None


def _start(code: str, site: Path | None) -> subprocess.Popen[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    if site is not None:
        env["PYTHONPATH"] = str(site)
    return subprocess.Popen(
        [sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, cwd=Path(__file__).parent,
    )  # fmt: skip


def _output(proc: subprocess.Popen[str]) -> str:
    try:
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        proc.kill()  # no-op once it has exited
    assert proc.returncode == 0, stderr
    return stdout


def _run(code: str, site: Path | None) -> str:
    return _output(_start(code, site))


def _both(code: str, site: Path) -> tuple[str, str]:
    """``code``'s output from the installed shoal at ``site`` and from this checkout's, run
    side by side (one core each)."""
    compiled, pure = _start(code, site), _start(code, None)
    return _output(compiled), _output(pure)


def test_an_installed_shoal_runs_its_compiled_modules(installed: Path) -> None:
    """With a C compiler (CI has one) every per-tick module is an extension, and its mypyc
    runtime lies inside the package; without one, all of them are the Python modules."""
    files = json.loads(
        _run(f"import importlib, json; print(json.dumps([importlib.import_module(m).__file__ "
             f"for m in {COMPILED!r}]))", installed)
    )  # fmt: skip
    assert all(f.startswith(str(installed / "shoal")) for f in files), files
    suffix = ".so" if _compiler() else ".py"
    assert [Path(f).suffix for f in files] == [suffix] * len(COMPILED), files
    runtime = sorted(p.name for p in installed.glob("*.so"))
    assert runtime == [], runtime  # nothing at the top level of site-packages


def test_compiled_and_pure_modules_give_the_same_bits(installed: Path) -> None:
    """The installed (compiled) shoal against this checkout's Python modules (an editable
    install, as the README's test command makes, runs them as Python: checked first)."""
    assert all(importlib.import_module(m).__file__.endswith(".py") for m in COMPILED)  # type: ignore[union-attr]
    child = _start(DIGESTS + "import json, sys; json.dump(out, sys.stdout)", installed)
    here: dict[str, Any] = {}
    exec(DIGESTS, here)  # the same code, in this process, while the child runs it compiled
    pure = here["out"]
    compiled = json.loads(_output(child))
    assert set(compiled) == {"obstacles", "passage", "crossing", "robotarium", "obstacles/0",
                             "obstacles/1", "crossing/0", "crossing/1", "obstacles/gap/0",
                             "obstacles/unicycle/0"}  # fmt: skip
    assert compiled == pure
    assert pure["obstacles"] == simulate(load_scenario("obstacles")).digest()


RECORDS = """
import copy, dataclasses, json, pickle
from shoal.agent.controller import Controller
from shoal.bus.messages import AgentState
from shoal.world.loader import load_scenario
a = AgentState(agent_id=1, tick=2, position=(0.5, -1.0), omega=False, bid=1.0, sigma=2.0, theta=0.0)
b = dataclasses.replace(a, tick=3)
memory = Controller(load_scenario("default").agent_config(2)).start()
out = {
    "equal": a == AgentState(1, 2, (0.5, -1.0), False, 1.0, 2.0, 0.0), "differ": a != b,
    "hash": hash(a) == hash(AgentState(1, 2, (0.5, -1.0), False, 1.0, 2.0, 0.0)),
    "repr": repr(b), "fields": [f.name for f in dataclasses.fields(memory)],
    "pickled": pickle.loads(pickle.dumps(a)) == a and pickle.loads(pickle.dumps(memory)) == memory,
    "copied": copy.deepcopy(b) == b,
}
try:
    a.tick = 5  # type: ignore[misc]
    out["assigned"] = True
except AttributeError:
    out["assigned"] = False
out["tick"] = a.tick
print(json.dumps(out))
"""


def test_the_messages_keep_their_dataclass_behaviour_in_both_builds(installed: Path) -> None:
    """The per-tick records (bus/messages.py, the controller's Memory) have their own
    ``__init__`` for speed: equality, hashing, repr, fields, replace, pickling and copying are
    the dataclass's in either build, and compiled, a field cannot be assigned (``Final``)."""
    compiled, pure = (json.loads(out) for out in _both(RECORDS, installed))
    for out in (compiled, pure):
        assert out["equal"] and out["differ"] and out["hash"]
        assert out["pickled"] and out["copied"]
        assert out["repr"] == (
            "AgentState(agent_id=1, tick=3, position=(0.5, -1.0), omega=False, bid=1.0, "
            "sigma=2.0, theta=0.0)"
        )
        assert out["fields"] == ["smoothed", "evasion", "bid", "sigma_consensus", "busy", "route",
                                 "calm", "planned", "known"]  # fmt: skip
    if _compiler():
        assert compiled["assigned"] is False and compiled["tick"] == 2


def test_the_filter_benchmark_sees_the_compiled_controllers_calls(installed: Path) -> None:
    """A patch cannot reach a call made within compiled code; ``shoal bench --filter`` records
    through the controller's source, and finds the same calls as in the pure build."""
    code = (
        "import json; from shoal.tools.bench.filter import bench_filter; "
        "print(json.dumps(bench_filter(repeats=1)))"
    )
    compiled, pure = (json.loads(out) for out in _both(code, installed))
    assert compiled["active_share"] == pure["active_share"] > 0
    assert compiled["filter_us_active"] > 0 and compiled["sensed_per_call_median"] > 0
