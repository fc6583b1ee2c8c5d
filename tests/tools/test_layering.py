"""The layering contracts of pyproject.toml ([tool.importlinter]) hold, and they catch a break:
checked on a copy of the tree assembled as the installed package, with and without a forbidden
import added."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LINT = Path(sys.executable).parent / "lint-imports"


def _tree(dest: Path) -> Path:
    """shoal/ as the wheel lays it out: src/shoal's files with every folder pyproject.toml maps
    into it (agent/, bus/, geometry/, world/, tools/)."""
    pkg = dest / "shoal"
    shutil.copytree(ROOT / "src" / "shoal", pkg, ignore=shutil.ignore_patterns("__pycache__"))
    mapping = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    for package, folder in mapping["tool"]["setuptools"]["package-dir"].items():
        if package != "shoal":
            shutil.copytree(ROOT / folder, pkg / package.removeprefix("shoal."),
                            ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    return pkg


def _lint(site: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [str(LINT), "--config", str(ROOT / "pyproject.toml"), "--no-cache"],
        env={**os.environ, "PYTHONPATH": str(site)}, cwd=site,
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip


@pytest.mark.skipif(not LINT.exists(), reason="import-linter is a dev dependency")
@pytest.mark.parametrize(
    ("module", "line", "contract"),
    [
        ("bus/keys.py", "import shoal.agent.formation", "bus imports nothing else"),
        ("bus/keys.py", "import shoal.geometry.safety", "bus imports nothing else"),
        ("geometry/safety.py", "import shoal.world.graph", "geometry imports bus only"),
        ("world/graph.py", "import shoal.tools.simulator", "never tools"),
        ("agent/formation.py", "import shoal.world.graph", "do not import each other"),
        ("tools/commands/plot.py", "import shoal.tools.commands.run", "no command imports"),
        ("tools/commands/guard.py", "import shoal.tools.commands.robots", "no command imports"),
        ("tools/procs/zygote.py", "import shoal.tools.commands.agent", "no import cycle"),
        ("tools/log/replay.py", "import shoal.tools.procs.launch", "no import cycle"),
        ("tools/foxglove/views.py", "import shoal.tools.foxglove.export", "no import cycle"),
    ],
)
def test_each_contract_holds_and_fails_on_a_forbidden_import(
    tmp_path: Path, module: str, line: str, contract: str
) -> None:
    pkg = _tree(tmp_path)
    kept = _lint(tmp_path)
    assert kept.returncode == 0, kept.stdout + kept.stderr
    target = pkg / module
    target.write_text(target.read_text(encoding="utf-8") + f"\n{line}  # noqa\n", encoding="utf-8")
    broken = _lint(tmp_path)
    assert broken.returncode == 1, broken.stdout
    verdicts = [
        line for line in broken.stdout.splitlines()
        if contract in line and line.endswith(("KEPT", "BROKEN"))
    ]  # fmt: skip
    assert verdicts and all(v.endswith("BROKEN") for v in verdicts), broken.stdout


def test_pyproject_lists_every_package_the_tree_holds() -> None:
    """The package list is written once, in pyproject.toml (setup.py reads its package-dir):
    a new subpackage left out of it would be missing from the wheel, not from a checkout."""
    import tomllib

    root = Path(__file__).resolve().parents[2]
    tool = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))["tool"]
    listed = set(tool["setuptools"]["packages"])
    found = set()
    for package, folder in tool["setuptools"]["package-dir"].items():
        for init in (root / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(root / folder)
            found.add(".".join([package, *rel.parts]))
    assert found == listed
