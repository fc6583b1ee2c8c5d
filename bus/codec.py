"""msgpack encoding of every message on the wire, with a schema version.

Every message is a msgpack map with ``v`` (schema version) and ``k`` (kind). Floats travel as
float64, so a position round-trips bit for bit. Decoding validates everything — kind, version,
types, lengths, finiteness — and raises :class:`~shoal.bus.errors.DecodeError` on any deviation; a
receiver counts and drops such messages and never crashes on them.
"""

from __future__ import annotations

import reprlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from operator import attrgetter, itemgetter
from typing import Any, TypeVar

import msgpack

from shoal.bus.errors import ConfigError, DecodeError
from shoal.bus.fields import table
from shoal.bus.messages import (
    AgentState,
    Command,
    Event,
    Mover,
    PlantRecord,
    RobotsRecord,
    Sensing,
    TickRecord,
)
from shoal.bus.types import (
    REACHED,
    AgentConfig,
    Clock,
    ControlParams,
    LimitSide,
    PathSpec,
    Reshape,
    Safety,
    Sinusoid,
    Vector,
    Waypoints,
)

SCHEMA = 2  # 2: sensing carries nearby agents; commands and ticks the filter flag; safety params
T = TypeVar("T")
M = TypeVar("M")

# Error messages show a wire value through this: bounded in length and depth, so that a value
# nested 1,000 deep (msgpack allows 1,024) cannot raise RecursionError instead of DecodeError.
_shown = reprlib.Repr()
_shown.maxlevel, _shown.maxstring, _shown.maxother = 2, 40, 40


def _wire_form(value: Any) -> Any:
    """What msgpack cannot pack as it is: a moving obstacle as [id, centre, radius, velocity,
    speed cap]; a numpy array as its list (tuples and lists both pack as arrays, and numpy's
    float64 as a float64, so a message's bytes do not depend on which it holds)."""
    if isinstance(value, Mover):
        return _MOVER(value)
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"cannot put a {type(value).__name__} on the wire")


_MOVER = attrgetter(*(f.name for f in fields(Mover)))  # its fields in their declared order


def _pack(kind: str, body: dict[str, Any]) -> bytes:
    return bytes(
        msgpack.packb({"v": SCHEMA, "k": kind, **body}, use_bin_type=True, default=_wire_form)
    )


def _unpack(kind: str, data: bytes) -> Mapping[str, Any]:
    try:
        msg = msgpack.unpackb(data, raw=False, strict_map_key=True)
    except Exception as exc:  # msgpack raises several unrelated types on garbage
        raise DecodeError(f"{kind}: not msgpack ({type(exc).__name__})") from None
    if not isinstance(msg, dict):
        raise DecodeError(f"{kind}: expected a map, got {type(msg).__name__}")
    version = msg.get("v")
    if type(version) is not int or version != SCHEMA:  # not 1.0 or true, though they equal 1
        raise DecodeError(
            f"{kind}: schema version {_shown.repr(version)}, this build speaks {SCHEMA}"
        )
    if msg.get("k") != kind:
        raise DecodeError(f"expected a {kind} message, got kind {_shown.repr(msg.get('k'))}")
    return msg


def _get(msg: Mapping[str, Any], name: str, check: Callable[[Any, str], T]) -> T:
    if name not in msg:
        raise DecodeError(f"{msg.get('k')}: missing field {name!r}")
    return check(msg[name], f"{msg.get('k')}.{name}")


def _int(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise DecodeError(f"{where}: expected an integer, got {type(value).__name__}")
    return value


def _bool(value: Any, where: str) -> bool:
    if not isinstance(value, bool):
        raise DecodeError(f"{where}: expected true/false, got {type(value).__name__}")
    return value


def _str(value: Any, where: str) -> str:
    if not isinstance(value, str):
        raise DecodeError(f"{where}: expected a string, got {type(value).__name__}")
    return value


def _float(value: Any, where: str) -> float:
    # Exact type tests are the hot path of every decode (bool is an int subclass: excluded).
    if type(value) is float:
        if value - value == 0.0:  # false for inf and nan
            return value
        raise DecodeError(f"{where}: {value!r} is not finite")
    if type(value) is int:
        try:
            return float(value)
        except OverflowError:
            raise DecodeError(f"{where}: {value} does not fit a float") from None
    raise DecodeError(f"{where}: expected a number, got {type(value).__name__}")


def _list(value: Any, where: str) -> list[Any]:
    if not isinstance(value, list):
        raise DecodeError(f"{where}: expected a list, got {type(value).__name__}")
    return value


def _vector(value: Any, where: str) -> Vector:
    items = _list(value, where)
    if len(items) not in (2, 3):
        raise DecodeError(f"{where}: expected 2 or 3 coordinates, got {len(items)}")
    return tuple([_float(x, where) for x in items])


def _vectors(value: Any, where: str) -> tuple[Vector, ...]:
    return tuple(_vector(v, where) for v in _list(value, where))


def _same_dim(dim: int, vectors: tuple[Vector, ...], where: str) -> None:
    """Every vector of one message has the same number of coordinates."""
    for v in vectors:
        if len(v) != dim:
            raise DecodeError(f"{where}: {len(v)} coordinates where the message has {dim}")


def _floats(value: Any, where: str) -> tuple[float, ...]:
    return tuple([_float(x, where) for x in _list(value, where)])


def _ints(value: Any, where: str) -> tuple[int, ...]:
    return tuple(_int(x, where) for x in _list(value, where))


def _bools(value: Any, where: str) -> tuple[bool, ...]:
    return tuple(_bool(x, where) for x in _list(value, where))


def _finite(*values: Any) -> bool:
    """Every value an exact, finite float: the common case the fast paths below accept."""
    for x in values:  # noqa: SIM110 (a loop: all() over a generator is slower here)
        if type(x) is not float or x - x != 0.0:
            return False
    return True


def _plain_vector(value: Any) -> bool:
    return type(value) is list and 2 <= len(value) <= 3 and _finite(*value)


def _map(value: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise DecodeError(f"{where}: expected a map, got {type(value).__name__}")
    return value


# -- configuration ------------------------------------------------------------------------------


def _path_body(p: PathSpec | None) -> dict[str, Any] | None:
    if p is None:
        return None
    if isinstance(p, Waypoints):
        body = {"type": "waypoints", "points": [list(x) for x in p.points], "speed": p.speed}
        if p.reach != REACHED:  # simulated runs' configurations stay byte for byte as they were
            body["reach"] = p.reach
        return body
    return {
        "type": "sinusoid",
        "start": list(p.start),
        "direction": list(p.direction),
        "normal": list(p.normal),
        "speed": p.speed,
        "amplitude": p.amplitude,
        "period": p.period,
    }


def _path_from(value: Any, where: str) -> PathSpec | None:
    if value is None:
        return None
    m = _map(value, where)
    kind = m.get("type")
    if kind == "waypoints":
        points = _vectors(m.get("points"), f"{where}.points")
        if not points:
            raise DecodeError(f"{where}.points: no waypoint")
        reach = m.get("reach")
        return Waypoints(
            points=points,
            speed=_float(m.get("speed"), f"{where}.speed"),
            reach=REACHED if reach is None else _float(reach, f"{where}.reach"),
        )
    if kind == "sinusoid":
        return Sinusoid(
            start=_vector(m.get("start"), f"{where}.start"),
            direction=_vector(m.get("direction"), f"{where}.direction"),
            normal=_vector(m.get("normal"), f"{where}.normal"),
            speed=_float(m.get("speed"), f"{where}.speed"),
            amplitude=_float(m.get("amplitude"), f"{where}.amplitude"),
            period=_float(m.get("period"), f"{where}.period"),
        )
    raise DecodeError(f"{where}.type: unknown path type {_shown.repr(kind)}")


# The float parameters, in ControlParams' order; `rounds` and `safety` travel after them.
_PARAMS = tuple(f.name for f in fields(ControlParams) if f.type == "float")
SAFETY_MODES = tuple(Safety)


CLOCKS = tuple(Clock)


def encode_config(c: AgentConfig, *, clock: Clock = Clock.LOCKSTEP) -> bytes:
    """An agent's configuration, with the run's clock ("lockstep" or "realtime")."""
    p = c.params
    return _pack(
        "config",
        {
            "clock": str(clock),
            "id": c.agent_id,
            "dim": c.dim,
            "dt": c.dt,
            "params": {
                **{k: getattr(p, k) for k in _PARAMS},
                "rounds": p.rounds,
                "safety": str(p.safety),
            },
            "senses": list(c.senses),
            "talks_to": list(c.talks_to),
            "offset": list(c.offset),
            "neighbour_offsets": [list(o) for o in c.neighbour_offsets],
            "formation_radius": c.formation_radius,
            "path": _path_body(c.path),
            "reshapes": [[r.tick, r.scale, r.rotate] for r in c.reshapes],
            **({"limits": [list(side) for side in c.limits]} if c.limits else {}),
        },
    )


def _limits(value: Any, where: str) -> tuple[LimitSide, ...]:
    """``limits``: [[n_x, n_y, c, nearest], ...], a unicycle's polygon of point velocities."""
    out = []
    for k, item in enumerate(_list(value, where)):
        side = _floats(item, f"{where}[{k}]")
        if len(side) != 4:
            raise DecodeError(f"{where}[{k}]: expected [n_x, n_y, c, nearest]")
        out.append((side[0], side[1], side[2], side[3]))
    return tuple(out)


def decode_config(data: bytes) -> AgentConfig:
    return decode_assignment(data)[0]


def decode_assignment(data: bytes) -> tuple[AgentConfig, Clock]:
    """The configuration and the run's clock."""
    m = _unpack("config", data)
    clock = _get(m, "clock", _str)
    if clock not in CLOCKS:
        raise DecodeError(f"config.clock: {clock!r} is not one of {', '.join(CLOCKS)}")
    pm = _get(m, "params", _map)
    safety = _get(pm, "safety", _str)
    if safety not in SAFETY_MODES:
        raise DecodeError(f"config.params.safety: {safety!r} is not one of filter, paper")
    params = ControlParams(
        **{k: _get(pm, k, _float) for k in _PARAMS},
        rounds=_get(pm, "rounds", _int),
        safety=Safety(safety),
    )
    reshapes = []
    for r in _get(m, "reshapes", _list):
        items = _list(r, "config.reshapes")
        if len(items) != 3:
            raise DecodeError("config.reshapes: expected [tick, scale, rotate]")
        reshapes.append(
            Reshape(
                _int(items[0], "config.reshapes"),
                _float(items[1], "config.reshapes"),
                _float(items[2], "config.reshapes"),
            )
        )
    try:
        config = _agent_config(m, params, tuple(reshapes))
    except ConfigError as exc:
        raise DecodeError(f"config.{exc.field}: {exc.problem}") from None
    return config, Clock(clock)


def _agent_config(
    m: Mapping[str, Any], params: ControlParams, reshapes: tuple[Reshape, ...]
) -> AgentConfig:
    return AgentConfig(
        agent_id=_get(m, "id", _int),
        dim=_get(m, "dim", _int),
        dt=_get(m, "dt", _float),
        params=params,
        senses=_get(m, "senses", _ints),
        talks_to=_get(m, "talks_to", _ints),
        offset=_get(m, "offset", _vector),
        neighbour_offsets=_get(m, "neighbour_offsets", _vectors),
        formation_radius=_get(m, "formation_radius", _float),
        path=_path_from(m.get("path"), "config.path"),
        reshapes=reshapes,
        limits=_limits(m.get("limits", []), "config.limits"),
    )


# -- the messages: each declared once, in bus/messages.py, with its wire form ---------------------


def _movers(value: Any, where: str) -> tuple[Mover, ...]:
    """``mv``: [[obstacle id, centre, radius, velocity, speed cap], ...]."""
    out = []
    for k, item in enumerate(_list(value, where)):
        at = f"{where}[{k}]"
        entry = _list(item, at)
        if len(entry) != 5:
            raise DecodeError(f"{at}: expected [id, centre, radius, velocity, speed cap]")
        mover = Mover(
            obstacle_id=_int(entry[0], f"{at}.id"),
            centre=_vector(entry[1], f"{at}.centre"),
            radius=_float(entry[2], f"{at}.radius"),
            velocity=_vector(entry[3], f"{at}.velocity"),
            speed_cap=_float(entry[4], f"{at}.speed_cap"),
        )
        if len(mover.velocity) != len(mover.centre):
            raise DecodeError(f"{at}: velocity and centre differ in coordinates")
        if not (mover.radius > 0 and mover.speed_cap >= 0):
            raise DecodeError(f"{at}: radius must be > 0 and speed cap ≥ 0")
        out.append(mover)
    return tuple(out)


# Per wire form (bus/fields.py FORMS): the check that decodes a value field by field, naming
# where it fails; and, for the fast path, a test that the value has exactly the type the
# encoder writes, with the expression that turns it into what the message holds.
CHECKS: dict[str, Callable[[Any, str], Any]] = {
    "int": _int, "float": _float, "bool": _bool, "str": _str, "vector": _vector,
    "vectors": _vectors, "ints": _ints, "floats": _floats, "bools": _bools, "movers": _movers,
}  # fmt: skip
_FAST = {
    "int": ("type({v}) is int", "{v}"),
    "float": ("type({v}) is float and {v} - {v} == 0.0", "{v}"),  # false for inf and nan
    "bool": ("type({v}) is bool", "{v}"),
    "str": ("type({v}) is str", "{v}"),
    "vector": ("_plain_vector({v})", "tuple({v})"),
    "vectors": ("type({v}) is list", "tuple(map(tuple, {v}))"),
    "ints": ("type({v}) is list", "tuple({v})"),
    "floats": ("type({v}) is list and _finite(*{v})", "tuple({v})"),
    "bools": ("type({v}) is list", "tuple({v})"),
}
# ... and for a list, the test of each item (a loop in the fast path, not a call per list).
_ITEM = {
    "vectors": "not _plain_vector(x)",
    "ints": "type(x) is not int",
    "bools": "type(x) is not bool",
}


@dataclass(frozen=True, slots=True)
class WireField:
    """One field of a message: its ``key`` in the msgpack map, the message attribute ``name``
    it carries, its wire ``form`` and ``check``, which decodes a wire value (raising
    :class:`DecodeError` that names where) into what the message holds. ``sparse``: written
    only when not empty, so that a run without the feature keeps its bytes (moving obstacles)."""

    key: str
    name: str
    form: str
    check: Callable[[Any, str], Any]
    sparse: bool = False


def wire_table(cls: type[Any]) -> tuple[WireField, ...]:
    """A message class's fields as bus/messages.py declares them, in wire order."""
    return tuple(
        WireField(key, name, form, CHECKS[form], sparse) for key, name, form, sparse in table(cls)
    )


def encoder(*tables: tuple[WireField, ...]) -> Callable[..., dict[str, Any]]:
    """The function that maps messages to their wire map, one message per table (a ``cmd``
    is a state and a command): a dict display of the fields always written, made from the
    tables' own keys and names, as fast as one written by hand; then the sparse fields that
    are not empty."""
    args = [f"m{i}" for i in range(len(tables))]
    items = [
        f"{f.key!r}: {arg}.{f.name}"
        for arg, table in zip(args, tables, strict=True)
        for f in table
        if not f.sparse
    ]
    if not all(f.name.isidentifier() for table in tables for f in table):
        raise ValueError("a message field's name must be an identifier")
    source = f"lambda {', '.join(args)}: {{{', '.join(items)}}}"  # keys as literals, names checked
    build: Callable[..., dict[str, Any]] = eval(source)
    sparse = [(f.key, f.name) for table in tables for f in table if f.sparse]
    if not sparse:
        return build
    if len(tables) != 1:
        raise ValueError("sparse fields are for one-message tables")

    def encode(message: Any) -> dict[str, Any]:
        body = build(message)
        for key, name in sparse:
            value = getattr(message, name)
            if value:
                body[key] = value
        return body

    return encode


def _decode_fields(table: tuple[WireField, ...], m: Mapping[str, Any]) -> dict[str, Any]:
    """The message's attributes from map ``m``, field by field, each checked (a sparse field
    that is absent is left to the message's default)."""
    return {f.name: _get(m, f.key, f.check) for f in table if not (f.sparse and f.key not in m)}


def fast_decoder(cls: type[M], table: tuple[WireField, ...]) -> Callable[[Mapping[str, Any]], Any]:
    """The common case in one pass, written from the table as :func:`encoder` is: every field
    present with the exact wire type the encoder writes (then the message), or None, and the
    field-by-field checks say what is wrong. Sparse fields present go through their checks."""
    dense = [f for f in table if not f.sparse]
    sparse = [f for f in table if f.sparse]
    if any(f.form not in _FAST for f in dense) or len(dense) < 2:
        return lambda m: None
    names = [f"v{i}" for i in range(len(dense))]
    test = " and ".join(_FAST[f.form][0].format(v=v) for f, v in zip(dense, names, strict=True))
    made = ", ".join(_FAST[f.form][1].format(v=v) for f, v in zip(dense, names, strict=True))
    present = " or ".join(f"{f.key!r} in m" for f in sparse)
    source = "\n".join([
        "def fast(m):",
        "    try:",
        f"        {', '.join(names)} = get(m)",
        "    except KeyError:",
        "        return None",
        f"    if not ({test}):",
        "        return None",
        *(line for f, v in zip(dense, names, strict=True) if f.form in _ITEM
          for line in (f"    for x in {v}:", f"        if {_ITEM[f.form]}:",
                       "            return None")),
        *([f"    if {present}:", f"        return cls({made}, **_decode_fields(sparse, m))"]
          if sparse else []),
        f"    return cls({made})",
    ])  # fmt: skip
    scope = {**globals(), "cls": cls, "get": itemgetter(*(f.key for f in dense)),
             "sparse": tuple(sparse)}  # fmt: skip
    exec(source, scope)  # keys and forms from the tables, names checked by encoder()
    fast: Callable[[Mapping[str, Any]], M | None] = scope["fast"]
    return fast


def _sensing_shape(s: Sensing) -> None:
    oc, ap = s.obstacle_centres, s.agent_positions
    if not len(s.obstacle_ids) == len(oc) == len(s.obstacle_radii):
        raise DecodeError("sensing: obstacle ids, centres and radii differ in length")
    if len(s.agent_ids) != len(ap):
        raise DecodeError("sensing: agent ids and positions differ in length")
    dim = len(s.position)
    for v in (*oc, *ap):  # one loop on the common path; _same_dim says which list is wrong
        if len(v) != dim:
            _same_dim(dim, oc, "sensing.oc")
            _same_dim(dim, ap, "sensing.ap")
    if s.movers:
        _same_dim(dim, tuple([v.centre for v in s.movers]), "sensing.mv")


def _tick_shape(t: TickRecord) -> None:
    if t.headings and len(t.headings) != len(t.positions):
        raise DecodeError("tick: headings and positions differ in length")
    if len(t.mover_centres) != len(t.mover_velocities):
        raise DecodeError("tick: mover centres and velocities differ in length")
    n = len(t.positions)
    per_agent = (t.velocities, t.omega, t.bid, t.sigma, t.theta, t.alive, t.filtered)
    if any(len(x) != n for x in per_agent):
        raise DecodeError("tick: per-agent fields differ in length")
    if n:
        movers = (*t.mover_centres, *t.mover_velocities)
        _same_dim(len(t.positions[0]), (*t.positions, *t.velocities, *movers), "tick.pos")


def _robots_shape(r: RobotsRecord) -> None:
    if r.ages and len(r.ages) != len(r.twists):
        raise DecodeError("robots: ages and twists differ in length")
    if any(len(t) != 3 for t in r.twists):
        raise DecodeError("robots.twist: each is [linear x, linear y, angular z]")


def _plant_shape(r: PlantRecord) -> None:
    n = len(r.bodies)
    if len(r.velocities) != n or any(len(x) not in (0, n) for x in (r.yaws, r.turn_rates)):
        raise DecodeError("plant: per-robot fields differ in length")
    if len(r.motor_speeds) != len(r.motor_efforts):
        raise DecodeError("plant: motor speeds and efforts differ in length")
    if n:
        _same_dim(len(r.bodies[0]), (*r.bodies, *r.velocities), "plant.body")
    if any(len(c) != 3 for c in r.contacts):
        raise DecodeError("plant.contact: each is [agent, what it touched, depth]")


def _whole(message: Any) -> None:
    """No check across fields: each field's own is all."""


@dataclass(frozen=True, slots=True)
class Kind:
    """What the codec knows of one message class: its ``kind`` on the wire, its fields, how
    they are written and read, and ``shape``, the checks across fields (raising DecodeError)."""

    kind: str
    cls: type[Any]
    table: tuple[WireField, ...]
    write: Callable[[Any], dict[str, Any]]
    fast: Callable[[Mapping[str, Any]], Any]
    shape: Callable[[Any], None]

    def decode(self, data: bytes) -> Any:
        """A message of this kind from its bytes, every field and shape checked."""
        m = _unpack(self.kind, data)  # read(m), inlined: a call less on every message
        message = self.fast(m)
        if message is None:
            message = self.cls(**_decode_fields(self.table, m))
        self.shape(message)
        return message

    def read(self, m: Mapping[str, Any]) -> Any:
        message = self.fast(m)
        if message is None:
            message = self.cls(**_decode_fields(self.table, m))
        self.shape(message)
        return message

    @classmethod
    def of(cls, kind: str, message: type[Any], shape: Callable[[Any], None] = _whole) -> Kind:
        table = wire_table(message)
        return cls(kind, message, table, encoder(table), fast_decoder(message, table), shape)


KINDS = {
    Sensing: Kind.of("sensing", Sensing, _sensing_shape),  # world → agent
    AgentState: Kind.of("state", AgentState),  # agent → neighbours
    Command: Kind.of("cmd", Command),  # agent → world, with the state (encode_report)
    TickRecord: Kind.of("tick", TickRecord, _tick_shape),  # world → all
    Event: Kind.of("event", Event),
    RobotsRecord: Kind.of("robots", RobotsRecord, _robots_shape),
    PlantRecord: Kind.of("plant", PlantRecord, _plant_shape),
}
Message = Sensing | AgentState | TickRecord | Event | RobotsRecord | PlantRecord


def encode(message: Message) -> bytes:
    """Any message but a command (:func:`encode_report`) as its msgpack map."""
    k = KINDS[type(message)]
    return _pack(k.kind, k.write(message))


def decode(cls: type[M], data: bytes) -> M:
    """A message of class ``cls`` from its bytes, every field and shape checked."""
    message: M = KINDS[cls].decode(data)
    return message


SENSING, STATE, TICK = KINDS[Sensing].table, KINDS[AgentState].table, KINDS[TickRecord].table
EVENT, ROBOTS, PLANT = KINDS[Event].table, KINDS[RobotsRecord].table, KINDS[PlantRecord].table
# A command travels with the state it was computed from: its id and tick are the state's.
COMMAND = tuple(f for f in KINDS[Command].table if f.key not in {g.key for g in STATE})
_encode_report = encoder(STATE, COMMAND)
_STATE, _COMMAND = KINDS[AgentState], KINDS[Command]


def encode_report(state: AgentState, command: Command) -> bytes:
    """The command of a tick, carrying what the agent announced that tick (for the record)."""
    return _pack("cmd", _encode_report(state, command))


def decode_report(data: bytes) -> tuple[AgentState, Command]:
    m = _unpack("cmd", data)
    state, command = _STATE.read(m), _COMMAND.read(m)
    _same_dim(len(state.position), (command.velocity,), "cmd.vel")
    return state, command


# The names the processes call: each message's encoder is encode; its decoder, decode of it.
encode_sensing = encode_state = encode_tick = encode_event = encode_robots = encode_plant = encode
decode_sensing: Callable[[bytes], Sensing] = KINDS[Sensing].decode
decode_state: Callable[[bytes], AgentState] = KINDS[AgentState].decode
decode_tick: Callable[[bytes], TickRecord] = KINDS[TickRecord].decode
decode_event: Callable[[bytes], Event] = KINDS[Event].decode
decode_robots: Callable[[bytes], RobotsRecord] = KINDS[RobotsRecord].decode
decode_plant: Callable[[bytes], PlantRecord] = KINDS[PlantRecord].decode


def encode_document(kind: str, body: Mapping[str, Any]) -> bytes:
    """A free-form map (``summary``, ``scenario``) of strings, numbers, booleans and None."""
    return _pack(kind, {"body": dict(body)})


_SCALARS = (type(None), bool, int, float, str)


def decode_document(kind: str, data: bytes) -> dict[str, Any]:
    """The body: names to strings, numbers (any float: inf marks an unbounded figure), booleans
    or None. A nested value or a name that is not a string is refused: readers print and store
    these values as they are."""
    body = dict(_get(_unpack(kind, data), "body", _map))
    for name, value in body.items():
        if type(name) is not str:
            raise DecodeError(f"{kind}.body: a name that is not a string")
        if type(value) not in _SCALARS:
            raise DecodeError(f"{kind}.body.{name[:40]}: a {type(value).__name__}, not a scalar")
    return body
