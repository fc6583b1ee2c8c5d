"""The code stays readable: no function of agent/, bus/, geometry/ or world/ longer than 80
lines, the world's tick loop only I/O around the run's step (world/step.py), under 40, and one
class per name across the package."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORE = ("agent", "bus", "geometry", "world")
LONGEST = 80  # lines, decorators and docstring included


def _functions(path: Path) -> dict[str, int]:
    """Every function and method of ``path`` (qualified name) and its length in lines."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: dict[str, int] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    start = min([child.lineno, *(d.lineno for d in child.decorator_list)])
                    out[name] = (child.end_lineno or child.lineno) - start + 1
                visit(child, name + ".")

    visit(tree, "")
    return out


def test_no_function_of_the_core_is_over_80_lines() -> None:
    long = {
        f"{path.relative_to(ROOT)}:{name}": lines
        for folder in CORE
        for path in sorted((ROOT / folder).rglob("*.py"))
        for name, lines in _functions(path).items()
        if lines > LONGEST
    }
    assert not long, long


def test_the_worlds_tick_loop_is_short() -> None:
    lines = _functions(ROOT / "world" / "process.py")["World._run"]
    assert lines < 40, lines


def test_the_measure_sees_a_long_function(tmp_path: Path) -> None:
    body = "".join(f"        x{k} = {k}\n" for k in range(LONGEST))
    (tmp_path / "long.py").write_text(f"class A:\n    def f(self):\n{body}", encoding="utf-8")
    assert _functions(tmp_path / "long.py")["A.f"] == LONGEST + 1


def test_one_class_per_name() -> None:
    """Two classes of one name (two ``AgentSpec``, two ``Arrival``) make every import a guess."""
    where: dict[str, list[str]] = {}
    for folder in (*CORE, "tools", "src"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.parse(path.read_text(encoding="utf-8")).body:
                if isinstance(node, ast.ClassDef):
                    where.setdefault(node.name, []).append(str(path.relative_to(ROOT)))
    assert not {name: paths for name, paths in where.items() if len(paths) > 1}
