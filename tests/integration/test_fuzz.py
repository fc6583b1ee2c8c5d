"""Bad input, fuzzed: every message decoder, the scenario loader, and every
process of a run over a real router. docs/fuzzing.md has the targets, cases and findings.

Properties:

- **decoders** (``bus.codec.decode_*``): on any bytes, each returns a valid object (exact types,
  every float finite, vectors of 2 or 3 coordinates that agree within the message, per-agent
  lists of one length, documents of scalars) or raises ``DecodeError``; nothing else escapes,
  and no case takes long. Valid messages round-trip bit for bit.
- **loader** (``world.loader.parse_scenario``): on any text, a valid ``Scenario`` or a
  ``ScenarioError`` whose message starts with the field it names; no warning but a ScenarioWarning.
- **processes** (integration): a run under a stream of bad payloads on every key finishes, its
  log verifies bit for bit, and the world and every agent counted exactly the bad payloads meant
  for them (nothing well-formed is forged here: that is access control, docs/fuzzing.md).

Inputs: raw random bytes; arbitrary msgpack (every type, NaN/±inf, ±1e308, the 64-bit extremes,
extension types and timestamps); envelopes with the right version and kind and random fields;
valid messages of another kind; *structured* mutations of valid messages (fields dropped,
retyped or replaced, nested elements changed, schema version and kind changed) followed by
byte-level damage (truncated, flipped, appended, inserted); and hand-made edge cases (nesting
1,020 deep, length headers promising 4 GiB, 100,000-element lists). Scenario text: truncations of
every built-in file, structured mutations of the built-ins, and text-level damage.

One generator (``Pick``) serves two drivers: hypothesis (``DrawPick``: shrinkable, fewer cases,
since each example costs about a millisecond of hypothesis bookkeeping) and a seeded
``random.Random`` (``RandomPick``: the bulk of the cases). Both are deterministic: hypothesis runs
with ``derandomize=True`` and no example database, and the seeds are fixed, so CI always runs the
same cases. ``SHOAL_FUZZ_SCALE=10`` multiplies every count (a longer local run); the cases run
per target are printed at the end of the module.
"""

from __future__ import annotations

import contextlib
import copy
import math
import os
import random
import re
import struct
import time
import warnings
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from importlib import resources
from pathlib import Path
from typing import Any, Protocol, TypeVar

import msgpack
import pytest
import yaml
from conftest import client, shortened, start_run, unique
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from shoal.bus import codec
from shoal.bus.errors import DecodeError, WireError
from shoal.bus.keys import Keys, agent_of
from shoal.bus.links import publisher
from shoal.bus.messages import AgentState, Command, Event, Sensing, TickRecord
from shoal.bus.types import AgentConfig, ControlParams, Reshape, Sinusoid, Waypoints
from shoal.world.errors import ScenarioError, ScenarioWarning
from shoal.world.loader import builtin_names, load_scenario, parse_scenario, scenario_from_dict
from shoal.world.scenario import Scenario

SCALE = max(1, int(os.environ.get("SHOAL_FUZZ_SCALE", "1")))
BULK_DECODER_CASES = 2000 * SCALE  # per decoder, seeded random
HYPOTHESIS_DECODER_CASES = 150 * SCALE  # per decoder, hypothesis
ROUND_TRIP_CASES = 100 * SCALE  # per kind, hypothesis
BULK_LOADER_CASES = 600 * SCALE  # per loader strategy, seeded random
HYPOTHESIS_LOADER_CASES = 100 * SCALE  # per loader strategy, hypothesis
TRUNCATION_STRIDE = max(1, 8 // SCALE)  # bytes between truncation points (1: every offset)
BUS_CASES = 300  # bad payloads per key kind in the integration test
SLOW_S = 5.0  # no single decode or load may take this long: "no hang" (a loaded 2-core CI)
T = TypeVar("T")


def fuzz(examples: int) -> settings:
    return settings(
        max_examples=examples,
        derandomize=True,
        database=None,
        deadline=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


CASES: Counter[str] = Counter()  # cases run per target, printed at the end of the module
SLOWEST: dict[str, float] = {}


@contextlib.contextmanager
def case(target: str, shown: Any = None) -> Iterator[None]:
    CASES[target] += 1
    began = time.perf_counter()
    yield
    took = time.perf_counter() - began
    SLOWEST[target] = max(SLOWEST.get(target, 0.0), took)
    assert took < SLOW_S, f"{target}: one case took {took:.2f} s: {shown!r:.300}"


@pytest.fixture(scope="module", autouse=True)
def _report_cases(request: pytest.FixtureRequest) -> Iterator[None]:
    yield
    if not CASES:
        return
    lines = ["", "fuzz cases run (target, cases, slowest case):"]
    lines += [f"  {t:<44} {n:>7}  {SLOWEST.get(t, 0.0) * 1e3:8.1f} ms" for t, n in CASES.items()]
    lines.append(f"  {'total':<44} {sum(CASES.values()):>7}")
    reporter = request.config.pluginmanager.get_plugin("terminalreporter")
    capture = request.config.pluginmanager.get_plugin("capturemanager")
    with capture.global_and_fixture_disabled() if capture else contextlib.nullcontext():
        for line in lines:
            if reporter is not None:
                reporter.write_line(line)


# -- one generator, two drivers -------------------------------------------------------------------


class Pick(Protocol):
    """The choices a generator makes; hypothesis draws them, or a seeded Random does."""

    def between(self, lo: int, hi: int) -> int: ...
    def choice(self, options: Sequence[T]) -> T: ...
    def finite(self) -> float: ...  # finite float64
    def blob(self, most: int) -> bytes: ...
    def string(self, most: int) -> str: ...


FLOAT = st.floats(allow_nan=False, allow_infinity=False)  # float64: -0.0, subnormals, ±1.8e308


class DrawPick:
    def __init__(self, draw: st.DrawFn) -> None:
        self.draw = draw

    def between(self, lo: int, hi: int) -> int:
        return self.draw(st.integers(lo, hi))

    def choice(self, options: Sequence[T]) -> T:
        return options[self.draw(st.integers(0, len(options) - 1))]

    def finite(self) -> float:
        return self.draw(FLOAT)

    def blob(self, most: int) -> bytes:
        return self.draw(st.binary(max_size=most))

    def string(self, most: int) -> str:
        return self.draw(st.text(max_size=most))


_NOTABLE = [0.0, -0.0, 1.0, -1.0, 0.5, 5e-324, 2.2250738585072014e-308, 1e-300, 1e300,
            1.7976931348623157e308, -1.7976931348623157e308, 2.0**53, 2.0**63, 2.0**64]  # fmt: skip


class RandomPick:
    def __init__(self, seed: int) -> None:
        self.rng = random.Random(seed)

    def between(self, lo: int, hi: int) -> int:
        return self.rng.randint(lo, hi)

    def choice(self, options: Sequence[T]) -> T:
        return options[self.rng.randrange(len(options))]

    def finite(self) -> float:
        how = self.rng.randrange(4)
        if how == 0:
            return self.rng.choice(_NOTABLE)
        if how == 1:  # any finite bit pattern
            x: float = struct.unpack("<d", self.rng.randbytes(8))[0]
            return x if math.isfinite(x) else 0.0
        return self.rng.uniform(-100.0, 100.0)

    def blob(self, most: int) -> bytes:
        return self.rng.randbytes(self.rng.randint(0, most))

    def string(self, most: int) -> str:
        n = self.rng.randint(0, most)
        alphabet = "az09 _-./:[]{}\"'\\\n\t\x00é∑😀\u200b\ufeff"
        return "".join(self.rng.choice(alphabet) for _ in range(n))


def both(gen: Callable[..., T], *args: Any) -> st.SearchStrategy[T]:
    """A hypothesis strategy of ``gen(pick, *args)``."""
    return st.composite(lambda draw: gen(DrawPick(draw), *args))()


# -- valid messages -------------------------------------------------------------------------------

WIRE_INTS = (-(2**63), 2**64 - 1)  # what msgpack can carry; the packer refuses anything wider


def wire_int(p: Pick) -> int:
    return p.between(*WIRE_INTS) if p.between(0, 1) else p.between(-3, 1000)


def positive(p: Pick) -> float:
    return abs(p.finite()) or 1.0


_POSITIVE = {"alpha", "beta", "sensing_radius", "trigger_radius", "sigma_max", "speed_limit",
             "separation"}  # fmt: skip


def vec(p: Pick, dim: int) -> tuple[float, ...]:
    return tuple(p.finite() for _ in range(dim))


def vecs(p: Pick, dim: int, n: int) -> tuple[tuple[float, ...], ...]:
    return tuple(vec(p, dim) for _ in range(n))


def valid_object(p: Pick, kind: str) -> Any:
    """A random valid message of ``kind`` (values anywhere in their wire range)."""
    dim = p.choice([2, 3])
    if kind == "sensing":
        m = p.between(0, 4)
        q = p.between(0, 4)
        return Sensing(wire_int(p), vec(p, dim), tuple(wire_int(p) for _ in range(m)),
                       vecs(p, dim, m), tuple(p.finite() for _ in range(m)),
                       tuple(wire_int(p) for _ in range(q)), vecs(p, dim, q))  # fmt: skip
    if kind in ("state", "cmd"):
        s = AgentState(wire_int(p), wire_int(p), vec(p, dim), p.choice([False, True]),
                       p.finite(), p.finite(), p.finite())  # fmt: skip
        if kind == "state":
            return s
        return s, Command(s.agent_id, s.tick, vec(p, dim), p.choice([False, True]))
    if kind == "config":
        m = p.between(0, 4)
        path = p.choice(["none", "waypoints", "sinusoid"])
        spec: Waypoints | Sinusoid | None = None
        if path == "waypoints":
            spec = Waypoints(vecs(p, dim, p.between(1, 4)), p.finite())
        elif path == "sinusoid":
            v, x = [vec(p, dim) for _ in range(3)], [p.finite() for _ in range(3)]
            spec = Sinusoid(v[0], v[1], v[2], x[0], x[1], x[2])
        config = AgentConfig(
            agent_id=wire_int(p),
            dim=dim,
            dt=positive(p),  # a valid configuration (bus.types.config_problem): dt > 0, …
            params=ControlParams(
                **{k: positive(p) if k in _POSITIVE else p.finite() for k in _PARAMS},
                rounds=p.between(1, WIRE_INTS[1]),
                safety=p.choice(list(codec.SAFETY_MODES)),
            ),
            senses=tuple(wire_int(p) for _ in range(m)),
            talks_to=tuple(wire_int(p) for _ in range(p.between(0, 4))),
            offset=vec(p, dim),
            neighbour_offsets=vecs(p, dim, m),
            formation_radius=p.finite(),
            path=spec,
            reshapes=tuple(
                Reshape(wire_int(p), p.finite(), p.finite()) for _ in range(p.between(0, 2))
            ),
        )
        return config, p.choice(codec.CLOCKS)
    if kind == "tick":
        n = p.between(0, 5)
        return TickRecord(
            wire_int(p), vecs(p, dim, n), vecs(p, dim, n),
            tuple(p.choice([False, True]) for _ in range(n)),
            tuple(p.finite() for _ in range(n)), tuple(p.finite() for _ in range(n)),
            tuple(p.finite() for _ in range(n)), tuple(p.choice([False, True]) for _ in range(n)),
            tuple(p.choice([False, True]) for _ in range(n)),
        )  # fmt: skip
    if kind == "event":
        return Event(wire_int(p), wire_int(p), wire_int(p), p.string(40))
    # summary, scenario: names to scalars; any float (a summary's unbounded bound is inf)
    scalars: list[Callable[[], Any]] = [
        lambda: None, lambda: p.choice([False, True]), lambda: wire_int(p), p.finite,
        lambda: p.choice([math.inf, -math.inf, math.nan]), lambda: p.string(40),
    ]  # fmt: skip
    return {p.string(16): p.choice(scalars)() for _ in range(p.between(0, 8))}


KINDS = ["sensing", "state", "cmd", "config", "tick", "event", "summary", "scenario"]
ENCODE: dict[str, Callable[[Any], bytes]] = {
    "sensing": codec.encode_sensing,
    "state": codec.encode_state,
    "cmd": lambda r: codec.encode_report(*r),
    "config": lambda a: codec.encode_config(a[0], clock=a[1]),
    "tick": codec.encode_tick,
    "event": codec.encode_event,
    "summary": lambda d: codec.encode_document("summary", d),
    "scenario": lambda d: codec.encode_document("scenario", d),
}
DECODE: dict[str, Callable[[bytes], Any]] = {
    "sensing": codec.decode_sensing,
    "state": codec.decode_state,
    "cmd": codec.decode_report,
    "config": codec.decode_assignment,
    "tick": codec.decode_tick,
    "event": codec.decode_event,
    "summary": lambda b: codec.decode_document("summary", b),
    "scenario": lambda b: codec.decode_document("scenario", b),
}


# -- what a decoded object must look like ---------------------------------------------------------


def _finite(x: Any) -> None:
    assert type(x) is float and math.isfinite(x), x


def _integer(x: Any) -> None:
    assert type(x) is int, x


def _vector(v: Any, dim: int | None = None) -> int:
    assert type(v) is tuple and len(v) in (2, 3), v
    assert dim is None or len(v) == dim, (v, dim)
    for x in v:
        _finite(x)
    return len(v)


def _each(items: Any, check: Callable[[Any], Any]) -> None:
    assert type(items) is tuple, items
    for x in items:
        check(x)


def _boolean(b: Any) -> None:
    assert type(b) is bool, b


def _valid_state(s: Any) -> int:
    assert type(s) is AgentState
    _integer(s.agent_id)
    _integer(s.tick)
    _boolean(s.omega)
    for x in (s.bid, s.sigma, s.theta):
        _finite(x)
    return _vector(s.position)


def _valid_path(p: Any, dim: int) -> None:
    if p is None:
        return
    if type(p) is Waypoints:
        assert len(p.points) >= 1
        _each(p.points, lambda v: _vector(v, dim))
        _finite(p.speed)
        return
    assert type(p) is Sinusoid, p
    for v in (p.start, p.direction, p.normal):
        _vector(v, dim)
    for x in (p.speed, p.amplitude, p.period):
        _finite(x)


_PARAMS = ["alpha", "beta", "sensing_radius", "trigger_radius", "epsilon", "safety_margin",
           "heading_tau", "sigma_max", "boundary_layer", "speed_limit", "separation"]  # fmt: skip


def assert_valid(kind: str, obj: Any) -> None:
    """Every decoded object: exact types, finite floats, shapes that agree within the message."""
    if kind == "sensing":
        assert type(obj) is Sensing
        _integer(obj.tick)
        dim = _vector(obj.position)
        _each(obj.obstacle_ids, _integer)
        _each(obj.obstacle_centres, lambda v: _vector(v, dim))
        _each(obj.obstacle_radii, _finite)
        assert len(obj.obstacle_ids) == len(obj.obstacle_centres) == len(obj.obstacle_radii)
        _each(obj.agent_ids, _integer)
        _each(obj.agent_positions, lambda v: _vector(v, dim))
        assert len(obj.agent_ids) == len(obj.agent_positions)
    elif kind == "state":
        _valid_state(obj)
    elif kind == "cmd":
        state, command = obj
        dim = _valid_state(state)
        assert type(command) is Command
        assert (command.agent_id, command.tick) == (state.agent_id, state.tick)
        _vector(command.velocity, dim)
        assert type(command.filtered) is bool
    elif kind == "config":
        config, clock = obj
        assert clock in codec.CLOCKS
        assert type(config) is AgentConfig and config.dim in (2, 3)
        assert type(config.params) is ControlParams
        for name in _PARAMS:
            _finite(getattr(config.params, name))
        assert config.params.safety in codec.SAFETY_MODES
        for x in (config.params.rounds, config.agent_id):
            _integer(x)
        _finite(config.dt)
        _finite(config.formation_radius)
        _each(config.senses, _integer)
        _each(config.talks_to, _integer)
        _vector(config.offset, config.dim)
        _each(config.neighbour_offsets, lambda v: _vector(v, config.dim))
        assert len(config.neighbour_offsets) == len(config.senses)
        _valid_path(config.path, config.dim)
        for r in config.reshapes:
            assert type(r) is Reshape
            _integer(r.tick)
            _finite(r.scale)
            _finite(r.rotate)
    elif kind == "tick":
        assert type(obj) is TickRecord
        _integer(obj.tick)
        n = len(obj.positions)
        assert len({_vector(v) for v in (*obj.positions, *obj.velocities)}) <= 1, obj
        columns = (obj.velocities, obj.omega, obj.bid, obj.sigma, obj.theta, obj.alive,
                   obj.filtered)  # fmt: skip
        for column in columns:
            assert type(column) is tuple and len(column) == n
        _each(obj.omega, _boolean)
        _each(obj.alive, _boolean)
        _each(obj.filtered, _boolean)
        for column in (obj.bid, obj.sigma, obj.theta):
            _each(column, _finite)
    elif kind == "event":
        assert type(obj) is Event
        for x in (obj.tick, obj.level, obj.agent):
            _integer(x)
        assert type(obj.text) is str
    else:  # summary, scenario: a map of names to scalars
        assert type(obj) is dict
        for key, value in obj.items():
            assert type(key) is str, key
            assert value is None or type(value) in (bool, int, float, str), (key, value)


def decode_or_refuse(target: str, kind: str, data: bytes) -> Any | None:
    """The property: a valid object, or DecodeError (then None); anything else propagates."""
    with case(target, data):
        try:
            obj = DECODE[kind](data)
        except DecodeError as exc:
            assert str(exc), "a DecodeError says what is wrong"
            return None
        except Exception as exc:
            raise AssertionError(f"{kind}: {type(exc).__name__} on {data!r:.400}") from exc
        assert_valid(kind, obj)
        if kind == "config":  # decode_config is decode_assignment's first half
            assert codec.decode_config(data) == obj[0]
        return obj


# -- bad messages ---------------------------------------------------------------------------------

# Values a field is set to (longer strings and lists: special_payloads).
EXTREMES: list[Any] = [
    math.nan, math.inf, -math.inf, 1e308, -1e308, 1.7976931348623157e308, 5e-324, -0.0,
    2**63 - 1, -(2**63), 2**64 - 1, 2**32, -1, 0, 1, True, False, None, "", "1", b"", "x" * 300,
    [], {}, [0.0] * 300,
]  # fmt: skip
VERSIONS = [0, 2, -1, 1.0, True, "1", b"\x01", None, 2**64 - 1, [1], {"v": 1}, codec.SCHEMA]
KIND_NAMES = [*KINDS, "", "State", "states", "config ", "Σ", b"state", 1, None]


def wire_value(p: Pick, depth: int = 0) -> Any:
    """Any msgpack value: every scalar type, extremes, extension types, lists and maps."""
    how = p.between(0, 12 if depth < 3 else 9)
    if how == 0:
        return None
    if how == 1:
        return p.choice([False, True])
    if how == 2:
        return wire_int(p)
    if how == 3:
        return p.finite()
    if how == 4:
        return p.string(12)
    if how == 5:
        return p.blob(12)
    if how in (6, 7):
        return copy.deepcopy(p.choice(EXTREMES))
    if how == 8:
        return msgpack.ExtType(p.between(0, 127), p.blob(8))
    if how == 9:
        return msgpack.Timestamp(p.between(0, 2**34), p.between(0, 999_999_999))
    if how in (10, 11):
        return [wire_value(p, depth + 1) for _ in range(p.between(0, 5))]
    keys: list[Callable[[], Any]] = [
        lambda: p.string(8), lambda: p.blob(4), lambda: p.between(-5, 5)
    ]  # fmt: skip
    return {p.choice(keys)(): wire_value(p, depth + 1) for _ in range(p.between(0, 5))}


def pack(value: Any) -> bytes:
    return bytes(msgpack.packb(value, use_bin_type=True))


def _fields(kind: str) -> list[str]:
    return [k for k in msgpack.unpackb(ENCODE[kind](_SEEDS[kind])) if k not in ("v", "k")]


def paths_in(node: Any, at: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """The path of every value inside ``node`` (map keys and list indices)."""
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for key, value in items:
        yield (*at, key)
        if isinstance(value, dict | list) and value:
            yield from paths_in(value, (*at, key))


def _parent(root: Any, at: tuple[Any, ...]) -> Any:
    for key in at[:-1]:
        root = root[key]
    return root


def retyped(p: Pick, value: Any) -> Any:
    """The same value in another wire type, or a near miss of the right type."""
    options: list[Any] = [None, str(value)[:40], [value], {"x": value}, True]
    if type(value) is float:
        options += [int(value) if abs(value) < 2**63 else 0, -value, value * 1e308, math.nan]
    if type(value) is int:
        near = float(value) if value.bit_length() < 1024 else 1e308  # an int past any float
        options += [near, value != 0, -value if value < 2**63 else 0, 2**64 - 1]
    if type(value) is bool:
        options += [int(value), float(value)]
    if type(value) is str:
        options += [value.encode(), value * 50]
    if type(value) is list:
        options += [value[:-1], value + value, value[:1] * 9, [[v] for v in value],
                    {str(i): v for i, v in enumerate(value)}]  # fmt: skip
    if type(value) is dict:
        options += [list(value.values()), {}]
    return copy.deepcopy(p.choice(options))


def mutate(p: Pick, message: dict[Any, Any], odd: Callable[[Pick], Any]) -> None:
    """1-3 structural mutations in place: a field or element dropped, replaced by ``odd``,
    retyped, or set to an extreme; the version or kind changed; an extra field."""
    for _ in range(p.between(1, 3)):
        op = p.choice(["drop", "replace", "retype", "extreme", "drop", "retype", "version", "kind",
                       "extra"])  # fmt: skip
        inside = list(paths_in(message))
        if op == "version":
            message["v"] = copy.deepcopy(p.choice(VERSIONS))
        elif op == "kind":
            message["k"] = p.choice(KIND_NAMES)
        elif op == "extra":
            message[p.string(6)] = odd(p)
        elif inside:
            at = p.choice(inside)
            node = _parent(message, at)
            if op == "drop":
                del node[at[-1]]
            elif op == "replace":
                node[at[-1]] = odd(p)
            elif op == "retype":
                node[at[-1]] = retyped(p, node[at[-1]])
            else:
                node[at[-1]] = copy.deepcopy(p.choice(EXTREMES))


def damaged(p: Pick, data: bytes) -> bytes:
    """Byte-level damage, 4 times in 7: truncated, a byte flipped, bytes appended or inserted."""
    cut = p.choice(["none", "none", "none", "truncate", "flip", "append", "insert"])
    if cut == "none" or not data:
        return data
    at = p.between(0, len(data) - 1)
    if cut == "truncate":
        return data[:at]
    if cut == "flip":
        return data[:at] + bytes([data[at] ^ p.between(1, 255)]) + data[at + 1 :]
    extra = p.blob(8) or b"\xc1"
    return data + extra if cut == "append" else data[:at] + extra + data[at:]


def bad_payload(p: Pick, kind: str) -> bytes:
    """Something a stranger might put on the key of ``kind``; most are structured mutations."""
    family = p.choice(["bytes", "msgpack", "envelope", "other kind", "mutated", "mutated",
                       "mutated", "mutated"])  # fmt: skip
    if family == "bytes":
        return p.blob(300)
    if family == "msgpack":
        return pack(wire_value(p))
    if family == "envelope":  # right version and kind, every field random or missing
        message: dict[Any, Any] = {"v": codec.SCHEMA, "k": kind}
        for name in _fields(kind):
            if p.between(0, 3):
                message[name] = wire_value(p)
        return pack(message)
    if family == "other kind":
        return ENCODE[other := p.choice([k for k in KINDS if k != kind])](valid_object(p, other))
    message = msgpack.unpackb(ENCODE[kind](valid_object(p, kind)))
    mutate(p, message, wire_value)
    return damaged(p, pack(message))


def _raw_map(items: dict[str, bytes]) -> bytes:
    """A msgpack map whose values are given already packed (to nest deeper than packb will)."""
    assert len(items) < 16
    return bytes([0x80 | len(items)]) + b"".join(pack(k) + v for k, v in items.items())


def _deep(depth: int) -> bytes:
    return b"\x91" * depth + b"\xc0"  # [[[...[nil]...]]]; msgpack unpacks up to 1,024 levels


_SEEDS: dict[str, Any] = {
    "sensing": Sensing(3, (1.0, 2.0), (0, 4), ((4.0, 5.0), (6.0, 7.0)), (1.0, 0.5)),
    "state": AgentState(2, 5, (1.0, 2.0), False, 1.0, 1.0, 0.0),
    "cmd": (AgentState(2, 5, (1.0, 2.0), True, 1.0, 1.0, 0.0), Command(2, 5, (0.5, -0.5))),
    "config": (
        AgentConfig(2, 2, 0.01, ControlParams(alpha=1.0, beta=2.0, sensing_radius=5.0,
                    trigger_radius=4.0, epsilon=0.05, safety_margin=0.2, heading_tau=0.5,
                    sigma_max=8.0, rounds=2, boundary_layer=0.0),
                    (1, 3), (1, 3, 4), (-3.0, 3.0), ((0.0, 0.0), (-3.0, -3.0)), 8.5,
                    Sinusoid((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), 1.0, 2.0, 10.0),
                    (Reshape(100, 2.0, 0.5),)),
        "lockstep",
    ),
    "tick": TickRecord(9, ((0.1, 0.2),) * 2, ((1.0, 0.0),) * 2, (False, True), (1.0, 4.0),
                       (1.0, 1.0), (0.0, 0.0), (True, False), (False, True)),
    "event": Event(3, 3, 2, "agent 2 gone"),
    "summary": {"scenario": "x", "steps": 10, "min_clearance": None, "convergence_bound": math.inf},
    "scenario": {"name": "x", "yaml": "dt: 0.01\n"},
}  # fmt: skip


def special_payloads(kind: str) -> list[bytes]:
    """Hand-made edge cases: nesting where error messages show values, length headers that
    promise gigabytes, extension types, keys of the wrong type, huge and non-finite numbers,
    each field of a valid message set to each extreme."""
    body = msgpack.unpackb(ENCODE[kind](_SEEDS[kind]))
    packed = {k: pack(v) for k, v in body.items()}
    out = [
        b"", b"\xc0", b"\xc1", b"\x80", b"\x90", b"\xa0",
        b"\xdd\xff\xff\xff\xff", b"\xdf\xff\xff\xff\xff", b"\xdb\xff\xff\xff\xff",
        b"\xc6\xff\xff\xff\xff", b"\xc9\xff\xff\xff\xff\x01", b"\xd7\xff" + b"\xff" * 8,
        _deep(100_000), b"\x81\xa1v" * 50_000 + b"\xc0",
        _raw_map({"v": _deep(1020), "k": pack(kind)}),
        _raw_map({"v": pack(1), "k": _deep(1020)}),
        _raw_map({"v": b"\xd5\xff\x00\x00", "k": pack(kind)}),  # a timestamp of 2 bytes
        pack({"v": 1, "k": kind, 1: 2}), pack({b"v": 1, b"k": kind.encode()}),
        pack({**body, "v": msgpack.ExtType(1, b"x")}), pack({**body, "v": msgpack.Timestamp(0)}),
        pack({**body, "x": "y" * 100_000}), pack({**body, "x": list(range(100_000))}),
        pack([body]), pack(body) + b"\x00", pack(body)[:-1],
    ]  # fmt: skip
    for field, value in body.items():
        if field in ("v", "k"):
            continue
        out.append(_raw_map({**packed, field: _deep(1020)}))
        out += [pack({**body, field: bad}) for bad in EXTREMES]
        out.append(pack({**body, field: [0.0] * 100_000}))
        if isinstance(value, list) and value:
            out.append(pack({**body, field: [*value[:-1], math.nan]}))
            out.append(pack({**body, field: value * 3}))
            if isinstance(value[0], list):
                out.append(pack({**body, field: [[*value[0], 0.0], *value[1:]]}))
        if isinstance(value, dict):  # config params, a path, a document body
            inner = {k: pack(v) for k, v in value.items()}
            for name in value:
                out.append(pack({**body, field: {**value, name: math.inf}}))
                out.append(pack({**body, field: {**value, name: [[1.0]]}}))
                out.append(_raw_map({**packed, field: _raw_map({**inner, name: _deep(1020)})}))
    return out


# -- 1. decoders ----------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", KINDS)
def test_each_decoder_on_seeded_random_bad_payloads(kind: str) -> None:
    p = RandomPick(KINDS.index(kind))
    accepted = 0
    for _ in range(BULK_DECODER_CASES):
        payload = bad_payload(p, kind)
        accepted += decode_or_refuse(f"decode_{kind} (seeded random)", kind, payload) is not None
    assert accepted < BULK_DECODER_CASES / 2  # most are refused: the generator does its job


@pytest.mark.parametrize("kind", KINDS)
@fuzz(HYPOTHESIS_DECODER_CASES)
@given(data=st.data())
def test_each_decoder_on_hypothesis_bad_payloads(kind: str, data: st.DataObject) -> None:
    payload = data.draw(both(bad_payload, kind), label="payload")
    decode_or_refuse(f"decode_{kind} (hypothesis)", kind, payload)


@pytest.mark.parametrize("kind", KINDS)
def test_each_decoder_on_hand_made_edge_cases(kind: str) -> None:
    for payload in special_payloads(kind):
        decode_or_refuse(f"decode_{kind} (hand-made)", kind, payload)


@pytest.mark.parametrize("kind", KINDS)
@fuzz(ROUND_TRIP_CASES)
@given(data=st.data())
def test_valid_messages_round_trip_bit_for_bit(kind: str, data: st.DataObject) -> None:
    obj = data.draw(both(valid_object, kind), label="message")
    with case(f"round trip {kind}"):
        wire = ENCODE[kind](obj)
        back = DECODE[kind](wire)
        assert ENCODE[kind](back) == wire  # float64 bits (-0.0, subnormals) included
        if kind not in ("summary", "scenario"):  # documents may hold NaN, which != itself
            assert back == obj
        assert_valid(kind, back)


def _with(kind: str, **fields: Any) -> bytes:
    return pack({**msgpack.unpackb(ENCODE[kind](_SEEDS[kind])), **fields})


def _found() -> dict[str, tuple[str, bytes, str]]:
    config = msgpack.unpackb(ENCODE["config"](_SEEDS["config"]))
    packed = {k: pack(v) for k, v in config.items()}
    return {  # what each decoder once let through (docs/fuzzing.md): kind, payload, refusal
        "v nested 1,020 deep": ("state", _raw_map({"v": _deep(1020), "k": pack("state")}),
                                "schema version"),
        "k nested 1,020 deep": ("cmd", _raw_map({"v": pack(codec.SCHEMA), "k": _deep(1020)}),
                                "got kind"),
        "path type nested": ("config", _raw_map({**packed, "path": _raw_map(
            {"type": _deep(1020)})}), "unknown path type"),
        "v 1.0": ("event", _with("event", v=1.0), "schema version"),
        "v true": ("tick", _with("tick", v=True), "schema version"),
        "3-D centre, 2-D pos": ("sensing", _with("sensing", oc=[[4.0, 5.0, 0.0], [6.0, 7.0]]),
                                "sensing.oc"),
        "3-D vel, 2-D pos": ("cmd", _with("cmd", vel=[0.5, -0.5, 0.0]), "cmd.vel"),
        "2-D and 3-D rows": ("tick", _with("tick", pos=[[0.1, 0.2], [0.1, 0.2, 0.3]]), "tick.pos"),
        "dim 2**63 - 1": ("config", _with("config", dim=2**63 - 1), "config.dim"),
        "3-D offset, dim 2": ("config", _with("config", offset=[1.0, 2.0, 3.0]), "config.offset"),
        "no waypoint": ("config", _with("config", path={"type": "waypoints", "points": [],
                                                        "speed": 1.0}), "no waypoint"),
        "offsets ≠ senses": ("config", _with("config", senses=[1]), "one per agent"),
        # The wire now runs the controller's own check (bus.types.config_problem): a config
        # the agent could not run with is refused where it arrives, not after.
        "dt 0": ("config", _with("config", dt=0.0), "config.dt: must be > 0"),
        "nested summary value": ("summary", _with("summary", body={"a": [[1]]}), "not a scalar"),
        "bytes summary name": ("summary", _with("summary", body={b"a": 1}), "not a string"),
    }  # fmt: skip


@pytest.mark.parametrize("name", list(_found()))
def test_what_fuzzing_found_in_the_decoders_is_refused(name: str) -> None:
    kind, payload, message = _found()[name]
    with pytest.raises(DecodeError, match=message):
        DECODE[kind](payload)


def test_schema_versions_other_than_the_integer_1_are_refused() -> None:
    body = msgpack.unpackb(codec.encode_event(Event(1, 2, 0, "x")))
    for v in VERSIONS:
        data = pack({**body, "v": v})
        if v == codec.SCHEMA and type(v) is int:
            assert codec.decode_event(data) == Event(1, 2, 0, "x")
        else:
            with pytest.raises(DecodeError, match="schema version"):
                codec.decode_event(data)


@fuzz(HYPOTHESIS_DECODER_CASES)
@given(st.text(max_size=80) | st.from_regex(r"shoal/[^/]{0,12}/agent/[0-9a-z²٣]{0,12}/state"))
def test_run_and_agent_ids_in_keys(key: str) -> None:
    """Other runs' ids and odd agent ids: a bad run id is a WireError, agent_of never raises."""
    with case("Keys(run) / agent_of(key)", key):
        found = agent_of(key)
        assert found is None or (type(found) is int and 0 <= found < 10**9)
        try:
            keys = Keys(key)
        except WireError:
            return
        assert re.fullmatch(r"[A-Za-z0-9_-]{1,64}", keys.run)
        assert agent_of(keys.state(7)) == 7


# -- 2. the scenario loader -----------------------------------------------------------------------

BUILTINS = {
    name: resources.files("shoal.world.scenarios")
    .joinpath(f"{name}.yaml")
    .read_text(encoding="utf-8")
    for name in builtin_names()
}
PARSED = {name: yaml.safe_load(text) for name, text in BUILTINS.items()}
_ROOTS = {
    "yaml", "scenario", "name", "description", "dim", "seed", "dt", "duration", "agent_radius",
    "tolerance_factor", "control", "graph", "agents", "initial_noise", "leader", "obstacles",
    "reshape", "kinematics",
}  # fmt: skip


def load_or_refuse(target: str, text: str | dict[str, Any]) -> Scenario | None:
    """The loader's property: a valid Scenario, or a ScenarioError that names its field. The only
    warnings allowed are ScenarioWarnings: BetaWarning (a run that Theorem 1 does not cover) and
    DetourWarning (the leader will go round an obstacle on its path)."""
    with case(target, text), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            s = parse_scenario(text) if isinstance(text, str) else scenario_from_dict(text)
        except ScenarioError as exc:
            field = exc.field
            assert field and str(exc).startswith(f"{field}: "), str(exc)
            root = re.split(r"[.\[]", field, maxsplit=1)[0]
            assert root in _ROOTS or exc.problem.startswith("unknown field"), str(exc)
            assert len(str(exc)) < 2000, "an error message stays readable"
            s = None
        except Exception as exc:
            raise AssertionError(f"{type(exc).__name__} on {text!r:.600}") from exc
    assert all(issubclass(w.category, ScenarioWarning) for w in caught), [str(w) for w in caught]
    if s is not None:
        assert s.dim in (2, 3) and s.n >= 2 and s.steps >= 1
        for x in (s.dt, s.duration, *s.initial_positions.ravel(), *s.offsets.ravel()):
            assert math.isfinite(x)
    return s


def test_truncated_builtins_are_loaded_or_refused() -> None:
    """The real files cut at every TRUNCATION_STRIDE-th byte (a half-written file, a cut
    download), the cut falling inside multi-byte characters too."""
    loaded = 0
    for text in BUILTINS.values():
        raw = text.encode()
        for cut in range(0, len(raw), TRUNCATION_STRIDE):
            part = raw[:cut].decode("utf-8", errors="ignore")
            loaded += load_or_refuse("parse_scenario: truncated built-ins", part) is not None
    assert loaded > 0  # some prefixes are whole scenarios (a trailing obstacle cut off)


HUGE_AND_ODD: list[Any] = [
    math.nan, math.inf, -math.inf, 1e308, -1e308, 10**400, -(10**30), 2**63, 1e-320, -1, 0, -0.0,
    0.5, 1e9, 1e9 + 1, 1e-9, True, None, "", "1.0", "x" * 10_000, [], {}, [1.0] * 2000,
    [[0, 0]] * 500, {"a": 1}, [None], [[[]]],
]  # fmt: skip


def yaml_value(p: Pick, depth: int = 0) -> Any:
    how = p.between(0, 9 if depth < 2 else 7)
    leaves: list[Callable[[], Any]] = [
        lambda: None, lambda: p.choice([False, True]), lambda: p.between(-(10**6), 10**6), p.finite,
        lambda: p.string(10), lambda: copy.deepcopy(p.choice(HUGE_AND_ODD)),
    ]  # fmt: skip
    if how < 8:
        return leaves[how % len(leaves)]()
    if how == 8:
        return [yaml_value(p, depth + 1) for _ in range(p.between(0, 4))]
    return {p.string(8): yaml_value(p, depth + 1) for _ in range(p.between(0, 4))}


def mutated_scenario(p: Pick) -> dict[str, Any]:
    """A built-in, parsed, with 1-3 fields dropped, retyped, set to odd or huge values, or
    scaled (negative, zero, tiny, huge)."""
    data: dict[str, Any] = copy.deepcopy(PARSED[p.choice(sorted(PARSED))])
    for _ in range(p.between(1, 3)):
        at = p.choice(list(paths_in(data)))
        node = _parent(data, at)
        value = node[at[-1]]
        op = p.choice(["drop", "replace", "retype", "odd", "scale", "scale"])
        if op == "drop":
            del node[at[-1]]
        elif op == "replace":
            node[at[-1]] = yaml_value(p)
        elif op == "retype":
            node[at[-1]] = retyped(p, value)
        elif op == "odd":
            node[at[-1]] = copy.deepcopy(p.choice(HUGE_AND_ODD))
        elif isinstance(value, int | float) and not isinstance(value, bool):
            factor = p.choice([-1, 0, 1e-9, 1e-3, 0.5, 0.999, 1.001, 2, 1e3, 1e9, 1e300])
            node[at[-1]] = value * factor
    return data


def as_yaml(data: Any) -> str | None:
    try:
        return yaml.safe_dump(data, allow_unicode=True)
    except (yaml.YAMLError, ValueError):  # an integer too long to print, say
        return None


YAML_NOISE = ["[", "]", "{", "}", ":", ": ", "- ", "&a ", "*a", "!!python/object:os.system ",
              "!!binary ", "!!set ", "!!timestamp ", "<<: ", "? ", "|", ">", "#", "'", '"', "\t",
              "\x00", "\ufeff", "\\ud800", "%YAML 1.1\n", "---\n", "...\n", "1e999", "-.inf",
              ".nan", "0x10", "0o7", "2001-12-14", "~", "null", "yes", "Off", "\n  ", "[" * 400,
              "]" * 400, "[" * 5000, "{a: " * 400, "&x [*x]", "9" * 5000, "1:" * 3000 + "0",
              "- " * 1000]  # fmt: skip


def damaged_text(p: Pick) -> str:
    """A built-in file with lines deleted, duplicated or swapped, and YAML syntax inserted."""
    lines = BUILTINS[p.choice(sorted(BUILTINS))].splitlines(keepends=True)
    for _ in range(p.between(1, 4)):
        op = p.choice(["delete", "duplicate", "swap", "insert", "replace"])
        k = p.between(0, len(lines) - 1)
        if op == "delete" and len(lines) > 1:
            del lines[k]
        elif op == "duplicate":
            lines.insert(k, lines[k])
        elif op == "swap":
            j = p.between(0, len(lines) - 1)
            lines[k], lines[j] = lines[j], lines[k]
        else:
            noise = p.choice(YAML_NOISE) if p.between(0, 2) else p.string(6)
            at = p.between(0, len(lines[k]))
            end = at if op == "insert" else min(len(lines[k]), at + p.between(1, 6))
            lines[k] = lines[k][:at] + noise + lines[k][end:]
    return "".join(lines)


def test_mutated_builtins_seeded_random() -> None:
    p = RandomPick(100)
    for k in range(BULK_LOADER_CASES):
        data = mutated_scenario(p)
        text = as_yaml(data) if k % 4 == 0 else None  # a quarter through YAML text (slower)
        if text is None:
            load_or_refuse("scenario_from_dict: mutated built-ins", data)
        else:
            load_or_refuse("parse_scenario: mutated built-ins", text)


@fuzz(HYPOTHESIS_LOADER_CASES)
@given(both(mutated_scenario))
def test_mutated_builtins_hypothesis(data: dict[str, Any]) -> None:
    load_or_refuse("scenario_from_dict: mutated built-ins (hyp.)", data)


def test_damaged_yaml_text_seeded_random() -> None:
    p = RandomPick(101)
    for noise in YAML_NOISE:
        load_or_refuse("parse_scenario: damaged text", noise)
    for _ in range(BULK_LOADER_CASES // 2):
        load_or_refuse("parse_scenario: damaged text", damaged_text(p))


@fuzz(HYPOTHESIS_LOADER_CASES)
@given(both(damaged_text) | st.text(max_size=200))
def test_damaged_yaml_text_hypothesis(text: str) -> None:
    load_or_refuse("parse_scenario: damaged text (hyp.)", text)


def test_deep_nesting_odd_tags_and_huge_integers_in_a_scenario_are_field_errors() -> None:
    """Each once escaped as another exception: RecursionError (PyYAML's composer, then repr in
    an error message), AttributeError/KeyError/IndexError (PyYAML on a tagged bad scalar),
    ValueError (str() of an integer of over 4,300 digits, which YAML's base-60 integers make;
    numpy on a noise of -0.0), or took quadratic time (PyYAML's scanner on "[" nested
    thousands deep)."""
    base60 = ":".join(["1"] + ["0"] * 3000)  # 60**3000
    for text, field in [
        ("[" * 20_000 + "]" * 20_000, "yaml"), ("control: " + "[" * 600 + "]" * 600, "yaml"),
        ("dt: " + "[" * 90 + "]" * 90, "dt"), ("agents:\n" + "  - " * 2000 + "1", "yaml"),
        ("dt: !!timestamp x", "yaml"), ("dt: !!bool x", "yaml"), ("dt: !!int", "yaml"),
        (f"dim: -{base60}", "dim"), (f"seed: {base60}", "seed"), (f"dt: {base60}", "dt"),
    ]:  # fmt: skip
        with case("parse_scenario: hand-made", text), pytest.raises(ScenarioError) as info:
            parse_scenario(text)
        assert info.value.field == field and len(str(info.value)) < 200, str(info.value)
    # initial_noise: -0.0 passed "≥ 0", then numpy's uniform(0.0, -0.0) raised ValueError
    text = BUILTINS["default"].replace("initial_noise: 1.0", "initial_noise: -0.0")
    assert load_or_refuse("parse_scenario: hand-made", text) is not None
    nested: Any = 0
    for _ in range(5000):
        nested = [nested]
    for data, field in [({"dt": nested}, "dt"), ({"seed": 10**5000}, "seed"),
                        ({"dim": {"x": 10**5000}}, "dim")]:  # fmt: skip
        with pytest.raises(ScenarioError, match=rf"^{field}: ") as info:
            scenario_from_dict(data)
        assert len(str(info.value)) < 200


# -- 3. every process, over the bus ---------------------------------------------------------------

BUS_KINDS = ["sensing", "state", "cmd", "config", "tick", "event", "summary", "scenario"]


def refused_by_receiver(kind: str, payload: bytes, *, agent: int, dim: int, steps: int) -> bool:
    """Whether whoever listens on this key must drop the payload, whatever tick the run is at:
    it does not decode, or it names another agent, or has the wrong dimension, or a tick the run
    can never be at. A payload that passes would be taken as genuine: a forgery (access control,
    not fuzzing), never sent here."""
    try:
        obj = DECODE[kind](payload)
    except DecodeError:
        return True
    if kind == "sensing":  # agent: wrong dimension, tick ≤ the last, a radius ≤ 0
        dims = {len(obj.position), *(len(c) for c in obj.obstacle_centres)}
        return dims != {dim} or obj.tick < 0 or any(r <= 0 for r in obj.obstacle_radii)
    if kind == "state":  # each listener: not the key's agent, wrong dimension, out of reach
        return obj.agent_id != agent or len(obj.position) != dim or not -2 <= obj.tick <= steps + 1
    if kind == "cmd":  # world: not the key's agent, a tick that never comes, wrong dimension
        command = obj[1]
        return (
            command.agent_id != agent
            or not 0 <= command.tick < steps
            or len(command.velocity) != dim
        )
    return False  # a valid tick, event, summary or scenario would be taken as the world's


def bus_plan(keys: Keys, scn: Scenario) -> tuple[list[tuple[str, bytes]], Counter[str]]:
    """(key, payload) to publish, and who must count what: "world", "agent i", and per topic
    the payloads the logger must record."""
    p, n = RandomPick(2024), scn.n
    listeners = {
        j: [i for i in range(1, n + 1) if j in {*scn.agent_config(i).senses,
                                                *scn.agent_config(i).talks_to}]
        for j in range(1, n + 1)
    }  # fmt: skip
    plan: list[tuple[str, bytes]] = []
    expect: Counter[str] = Counter()
    for kind in BUS_KINDS:
        specials = iter([x for x in special_payloads(kind) if len(x) < 65_536])
        made = 0
        while made < BUS_CASES:
            payload = next(specials, None) or bad_payload(p, kind)
            j = 1 + made % n
            if not refused_by_receiver(kind, payload, agent=j, dim=scn.dim, steps=scn.steps):
                continue
            key = {
                "sensing": keys.sensing(j), "state": keys.state(j), "cmd": keys.command(j),
                "config": keys.config(j), "tick": keys.tick, "event": keys.event,
                "summary": keys.summary, "scenario": keys.scenario,
            }[kind]  # fmt: skip
            plan.append((key, payload))
            expect[f"topic {key}"] += 1
            if kind == "sensing":
                expect[f"agent {j}"] += 1
            elif kind == "state":
                for i in listeners[j]:
                    expect[f"agent {i}"] += 1
            elif kind == "cmd":
                expect["world"] += 1
            made += 1
        CASES[f"bus: {kind} payloads"] += made
    # Keys the world's agent/*/cmd subscription matches but no agent owns: all counted.
    for chunk in ["0", str(n + 1), "007", "abc", "999999999"]:
        key = f"{keys.root}/agent/{chunk}/cmd"
        for _ in range(10):
            payload = bad_payload(p, "cmd")
            if refused_by_receiver("cmd", payload, agent=-1, dim=scn.dim, steps=scn.steps):
                plan.append((key, payload))
                expect[f"topic {key}"] += 1
                expect["world"] += 1
                CASES["bus: cmd payloads on odd keys"] += 1
    p.rng.shuffle(plan)
    return plan, expect


@pytest.mark.integration
def test_every_process_drops_and_counts_fuzzed_payloads_and_the_run_stays_exact(
    router: str, tmp_path: Path
) -> None:
    from mcap.reader import make_reader

    from shoal.tools.log.reader import read_documents, read_trajectory
    from shoal.tools.procs.swarm import Swarm
    from shoal.tools.simulator import simulate
    from shoal.tools.verify import verify

    scenario = shortened(tmp_path, "sinusoid", duration=5.0)
    scn = load_scenario(scenario)
    run, other, out = unique("fuzz"), unique("fuzz-other"), tmp_path / "run.mcap"
    keys = Keys(run)
    plan, expect = bus_plan(keys, scn)
    strangers = [(Keys(other).sensing(1), ENCODE["sensing"](_SEEDS["sensing"])),
                 (Keys(other).state(2), ENCODE["state"](_SEEDS["state"])),
                 (Keys(other).command(2), ENCODE["cmd"](_SEEDS["cmd"])),
                 (Keys(other).tick, ENCODE["tick"](_SEEDS["tick"])),
                 (Keys(other).summary, ENCODE["summary"](_SEEDS["summary"]))] * 10  # fmt: skip
    CASES["bus: valid messages on another run's keys"] += len(strangers)
    with Swarm() as swarm, client(router) as session:
        r = start_run(swarm, session, router, str(scenario), run, out)
        r.watcher.until_tick(10)  # decodes strictly: used only before any garbage is out
        publishers: dict[str, Any] = {}
        for key, payload in [*plan, *strangers]:
            if key not in publishers:  # BLOCK, as the run's own: none of this may be dropped
                publishers[key] = publisher(session, key)
            publishers[key].put(payload)
        replies: dict[str, list[bytes]] = {}
        for chunk in ["0", str(scn.n + 1), "abc", "-1", "99999999999999999999", "1/x", "**", "1"]:
            got = session.get(f"{keys.root}/world/config/{chunk}", payload=b"\xc1", timeout=10)
            replies[chunk] = [x.ok.payload.to_bytes() for x in got if x.ok is not None]
            CASES["bus: configuration queries"] += 1
        # The last query went through the router after every put: the world, still ticking,
        # has them all queued before its next tick's commands, and so have the agents.
        assert r.world.popen.poll() is None, "the run ended before the fuzzing did: lengthen it"
        assert r.world.popen.wait(timeout=120) == 0, r.world.tail()
        assert r.logger.popen.wait(timeout=60) == 0, r.logger.tail()
        for agent in r.agents:
            assert agent.popen.wait(timeout=60) == 0, agent.tail()
        for child in (r.world, r.logger, *r.agents):
            child.done = True
        logs = {c.name: c.log.read_text(errors="replace") for c in (r.world, *r.agents)}
    assert {k: len(v) for k, v in replies.items()} == {k: int(k == "1") for k in replies}
    assert codec.decode_assignment(replies["1"][0])[0] == scn.agent_config(1)
    # The run finished and its log is the reference simulator's, bit for bit.
    assert verify(out).ok
    assert read_trajectory(out, dt=scn.dt).equals(simulate(scn))
    # Every bad payload was counted by the process it was meant for, and only those.
    summary = read_documents(out)["summary"]
    assert summary["dropped_messages"] == expect["world"]
    assert f"run finished; {expect['world']} bad messages dropped" in logs["world"]
    for i in range(1, scn.n + 1):
        assert f"agent {i}: {expect[f'agent {i}']} bad messages dropped" in logs[f"agent {i}"]
    # The logger recorded every payload on the run's keys, raw, and nothing of the other run.
    with out.open("rb") as f:
        log_summary = make_reader(f).get_summary()
    assert log_summary is not None and log_summary.statistics is not None
    counts = {
        log_summary.channels[c].topic: m
        for c, m in log_summary.statistics.channel_message_counts.items()
    }
    assert all(t.startswith(f"{keys.root}/") for t in counts)
    own = {keys.tick: scn.steps, keys.event: 1, keys.summary: 1, keys.scenario: 1}
    for i in range(1, scn.n + 1):
        own |= {keys.sensing(i): scn.steps, keys.state(i): scn.steps, keys.command(i): scn.steps}
    for name, count in expect.items():
        if name.startswith("topic "):
            topic = name.removeprefix("topic ")
            assert counts.get(topic) == count + own.get(topic, 0), topic


@pytest.mark.integration
def test_the_world_counts_commands_that_come_before_tick_0(router: str, tmp_path: Path) -> None:
    """Garbage on the command keys while the world still waits for everyone is counted too (no
    agent can command before it has sensed tick 0, so every such message is bad)."""
    from shoal.bus.links import watch_presence
    from shoal.bus.runtime import Inbox
    from shoal.tools.procs.swarm import Swarm

    scenario = shortened(tmp_path, "sinusoid", duration=0.5)
    scn = load_scenario(scenario)
    run = unique("early")
    keys = Keys(run)
    common = ["--run", run, "--connect", router]
    early = [(keys.command(1 + k % scn.n), bytes([k])) for k in range(23)]
    with Swarm() as swarm, client(router) as session:
        seen = Inbox()
        watching = watch_presence(session, keys.alive_world, seen)
        world = swarm.spawn("world", "world", ["world", str(scenario), *common,
                                               "--expect", "monitor"])  # fmt: skip
        for i in range(1, scn.n + 1):
            swarm.spawn(f"agent {i}", "agent", ["agent", "--id", str(i), *common])
        assert seen.get(timeout=30) is not None  # the world's token: it waits for the monitor
        for key, payload in early:
            publisher(session, key).put(payload)
        # The reply went out after the world's session had delivered every put above.
        assert [r for r in session.get(keys.config(1), timeout=10) if r.ok is not None]
        token = session.liveliness().declare_token(keys.alive_process("monitor"))
        assert swarm.expect_exit({"world", "agent"}, timeout=60) == []
        assert world.popen.returncode == 0, world.tail()
        log = world.log.read_text(errors="replace")
        del watching, token
    CASES["bus: commands before tick 0"] += len(early)
    assert f"run finished; {len(early)} bad messages dropped" in log
