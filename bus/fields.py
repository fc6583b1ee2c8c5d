"""A message's fields, each declared once with its wire form, and the code written from them.

A field of a message in bus/messages.py is one line, ``name: Final[Annotated[type, Wire(key)]]``:
its attribute, its type and its key in the msgpack map (docs/wire.md). Two things follow from
those lines and are written into bus/messages.py by ``python -m shoal.bus.fields`` (as CPython's
Argument Clinic writes the boilerplate beside its declarations): each class's ``__init__``, and
``WIRE``, the table bus/codec.py builds every encoder and decoder from.

Why written out, not made at import (a decorator, or ``dataclass``'s own ``__init__``): mypyc
compiles only the code it reads, and the messages are made every tick from compiled code. A
compiled ``__init__`` costs 766 instructions to make an ``AgentState`` from compiled code;
``dataclass``'s, made at import and so interpreted, costs 4,356 called positionally and 7,088
with keywords (callgrind, a probe module compiled by mypyc). A compiled class keeps no
``Annotated`` at run time either (its annotations become ``int``, ``tuple``), so the codec reads
``WIRE``, not the annotations; and ``WIRE`` is not a class attribute, which a compiled dataclass
would take for one more field. tests/bus/test_fields.py fails when what is written is not
what the declarations give.
"""

from __future__ import annotations

import ast
import dataclasses
import re
import sys
import typing
from pathlib import Path
from typing import Any, NamedTuple

# The wire forms of a field's type: bus/codec.py has a check (and a fast test) for each.
FORMS = {
    "int": "int",
    "float": "float",
    "bool": "bool",
    "str": "str",
    "Vector": "vector",
    "tuple[Vector, ...]": "vectors",
    "tuple[int, ...]": "ints",
    "tuple[float, ...]": "floats",
    "tuple[bool, ...]": "bools",
    "tuple[Mover, ...]": "movers",
}


class Wire(NamedTuple):
    """A field's wire form: its ``key`` in the message's map; ``default``, what a sender may
    leave out (``...``: none, the field is required); ``sparse``: written only when not empty
    or 0, so that a run without the feature keeps its bytes."""

    key: str
    default: Any = ...
    sparse: bool = False


class Declared(NamedTuple):
    """One declared field: attribute ``name``, its type as written, and its wire form (None
    for a record that travels as a list, ``Mover``)."""

    name: str
    type: str
    wire: Wire | None


def declared(cls: type[Any]) -> list[Declared]:
    """The fields of a message class as bus/messages.py declares them (the pure module: a
    compiled class has lost its annotations' text)."""
    hints = typing.get_type_hints(cls, include_extras=True)
    out = []
    for f in dataclasses.fields(cls):
        written = ast.parse(str(f.type), mode="eval").body  # Final[T] or Final[Annotated[T, W]]
        inner = written.slice if isinstance(written, ast.Subscript) else written
        meta = getattr(typing.get_args(hints[f.name])[0], "__metadata__", ())
        wires = [m for m in meta if isinstance(m, Wire)]
        if wires:  # Annotated[T, Wire(...)]: T
            if not (isinstance(inner, ast.Subscript) and isinstance(inner.slice, ast.Tuple)):
                raise ValueError(f"{cls.__name__}.{f.name}: expected Final[Annotated[T, Wire]]")
            inner = inner.slice.elts[0]
        out.append(Declared(f.name, ast.unparse(inner), wires[0] if wires else None))
    return out


def _packed(first: str, items: list[str], last: str, indent: str) -> list[str]:
    """``first`` + items joined by ", " + ``last``, wrapped within 100 columns (less the
    class's indent), each further line under the first item."""
    lines, line = [], first
    for k, item in enumerate(items):
        piece = item + ("," if k < len(items) - 1 else last)
        if len(indent) + len(line) + len(piece) + 1 > 100 and line.strip() != first.strip():
            lines.append(line.rstrip())
            line = " " * len(first)
        line += piece + " "
    return [*lines, line.rstrip()]


def init_source(fields: list[Declared], indent: str) -> list[str]:
    """A class's ``__init__``: its signature (in the fields' order, with their defaults) and
    every field assigned, a few to a line (tuple assignments, as fast compiled as one each)."""
    params = [
        f"{f.name}: {f.type}"
        + ("" if f.wire is None or f.wire.default is ... else f" = {f.wire.default!r}")
        for f in fields
    ]
    head = _packed("def __init__(self, ", params, ") -> None:  # fmt: skip", indent)
    body: list[list[str]] = [[]]
    for f in fields:
        line = body[-1] + [f.name]
        text = f"    {', '.join(f'self.{n}' for n in line)} = {', '.join(line)}"
        if len(indent) + len(text) > 100:
            body.append([f.name])
        else:
            body[-1] = line
    return head + [f"    {', '.join(f'self.{n}' for n in g)} = {', '.join(g)}" for g in body]


def wire_source(classes: list[type[Any]]) -> list[str]:
    """``WIRE``: per message class, "key:form" per field in the fields' order ("?" after the
    form of a sparse field). A module-level table, not a class attribute: a compiled dataclass
    would take a class attribute for one more field."""
    lines = ["WIRE: dict[type[Any], tuple[str, ...]] = {"]
    for cls in classes:
        rows = []
        for f in declared(cls):
            if f.wire is None or f.type not in FORMS:
                raise ValueError(f"{cls.__name__}.{f.name}: no Wire(key), or no form for {f.type}")
            rows.append(f'"{f.wire.key}:{FORMS[f.type]}{"?" if f.wire.sparse else ""}"')
        lines += _packed(f"    {cls.__name__}: (", rows, "),", "    ")
    return [*lines, "}  # fmt: skip"]


def table(cls: type[Any]) -> list[tuple[str, str, str, bool]]:
    """A message class's wire table from its ``WIRE`` (either build): (key, attribute, form,
    sparse) per field, in the fields' order."""
    names = [f.name for f in dataclasses.fields(cls)]
    wire: tuple[str, ...] = sys.modules[cls.__module__].WIRE.get(cls, ())
    if len(wire) != len(names):
        raise ValueError(f"{cls.__name__}: WIRE is stale (python -m shoal.bus.fields)")
    rows = []
    for w, name in zip(wire, names, strict=True):
        key, form = w.rstrip("?").split(":")
        rows.append((key, name, form, w.endswith("?")))
    return rows


BEGIN = "# Written by `python -m shoal.bus.fields` from the fields above; not by hand."
END = "# End of what is written."


def written(source: str, module: Any) -> str:
    """``source`` (bus/messages.py's text) with each class's written block made anew from
    the fields that ``module`` declares for that class."""
    out: list[str] = []
    cls, skipping = "", False
    for line in source.splitlines(keepends=True):
        if line.startswith("class "):
            cls = re.split(r"[(:]", line[6:])[0]
        if line.strip() == BEGIN:
            indent = line[: len(line) - len(line.lstrip())]
            if indent:  # in a class: its __init__
                body = [*init_source(declared(getattr(module, cls)), indent), ""]
            else:  # at the end of the module: every message's WIRE
                body = wire_source([c for c in _classes(module) if c.__name__ in _wired(source)])
            block = [BEGIN, *body, END]
            out += [f"{indent}{text}\n" if text else "\n" for text in block]
            skipping = True
        elif skipping:
            skipping = line.strip() != END
        else:
            out.append(line)
    return "".join(out)


def _classes(module: Any) -> list[type[Any]]:
    """The dataclasses ``module`` defines, in the order it defines them."""
    found = [
        v for v in vars(module).values() if isinstance(v, type) and dataclasses.is_dataclass(v)
    ]
    return [c for c in found if c.__module__ == module.__name__]


def _wired(source: str) -> set[str]:
    """The classes of ``source`` that declare a field with a wire form."""
    names, cls = set(), ""
    for line in source.splitlines():
        if line.startswith("class "):
            cls = re.split(r"[(:]", line[6:])[0]
        elif "Wire(" in line and line.startswith("    ") and ": Final[" in line:
            names.add(cls)
    return names


def main() -> None:
    from shoal.bus import fields, messages  # fields: this module under its name, not __main__

    path = Path(messages.__file__)
    if path.suffix != ".py":
        sys.exit(f"{path}: a compiled module; run this from a pure (editable) install")
    text = path.read_text(encoding="utf-8")
    new = fields.written(text, messages)
    if new != text:
        path.write_text(new, encoding="utf-8")
        print(f"{path}: written")


if __name__ == "__main__":
    main()
