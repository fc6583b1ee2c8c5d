"""Each message field is declared once (bus/messages.py, with its wire form); what follows from
the declarations — each class's ``WIRE`` and ``__init__``, the codec's tables — is what they
give, and every field survives the wire, a pickle and a copy with its own value."""

from __future__ import annotations

import copy
import dataclasses
import pickle
from pathlib import Path
from typing import Any

import pytest

from shoal.bus import codec, fields, messages
from shoal.bus.fields import FORMS, declared
from shoal.bus.messages import AgentState, Command, Mover

MESSAGES = list(codec.KINDS)


def test_what_is_written_is_what_the_fields_declare() -> None:
    """A field added, removed, renamed or given another type or key, and not written out."""
    source = Path(messages.__file__).read_text(encoding="utf-8")
    assert fields.written(source, messages) == source, "run: python -m shoal.bus.fields"


@pytest.mark.parametrize("cls", MESSAGES, ids=lambda c: c.__name__)
def test_every_field_of_a_message_has_a_wire_form_the_codec_reads(cls: type[Any]) -> None:
    for field in declared(cls):
        assert field.wire is not None, f"{cls.__name__}.{field.name}: no Wire(key)"
        assert FORMS[field.type] in codec.CHECKS, field
    table = codec.KINDS[cls].table
    assert [f.name for f in table] == [f.name for f in dataclasses.fields(cls)]
    assert len({f.key for f in table}) == len(table), "two fields with one key"


def _distinct(cls: type[Any], dim: int = 3) -> Any:
    """An instance whose every field holds a value no other field holds (no defaults); lists
    of two, vectors of three (a robot's twist)."""
    seed = iter(range(1, 1_000))

    def value(form: str) -> Any:
        k = next(seed)
        return {
            "int": k,
            "float": k + 0.25,
            "bool": k % 2 == 0,
            "str": f"s{k}",
            "vector": (k + 0.5,) * dim,
            "vectors": ((k + 0.5,) * dim,) * 2,
            "ints": (k, k + 1),
            "floats": (k + 0.75, k + 0.125),
            "bools": (True, k % 2 == 0),
            "movers": (Mover(k, (k + 0.5,) * dim, 0.5, (0.25,) * dim, 1.0),),
        }[form]

    return cls(**{f.name: value(f.form) for f in codec.KINDS[cls].table})


@pytest.mark.parametrize("cls", MESSAGES, ids=lambda c: c.__name__)
def test_every_field_crosses_the_wire_a_pickle_and_a_copy(cls: type[Any]) -> None:
    original = _distinct(cls)
    if cls is Command:  # a command travels with its state
        state = AgentState(original.agent_id, original.tick, (0.5,) * 3, False, 1.0, 1.0, 0.0)
        assert codec.decode_report(codec.encode_report(state, original)) == (state, original)
    else:
        assert codec.decode(cls, codec.encode(original)) == original
    for made in (pickle.loads(pickle.dumps(original)), copy.copy(original)):
        assert made == original
        for f in dataclasses.fields(cls):
            assert getattr(made, f.name) == getattr(original, f.name), f.name
