"""The wire contract: keys, msgpack codecs (exact round trips, every bad message refused with
DecodeError), and the Zenoh configuration's precedence."""

from __future__ import annotations

import dataclasses
import math
import struct
from pathlib import Path
from typing import Any

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from shoal.bus import codec
from shoal.bus.errors import DecodeError, WireError
from shoal.bus.keys import Keys, agent_of
from shoal.bus.messages import AgentState, Command, Event, RobotsRecord, Sensing, TickRecord
from shoal.bus.types import REACHED, ControlParams, Waypoints
from shoal.bus.zconfig import zenoh_config
from shoal.world.loader import builtin_names, load_scenario

FLOATS = st.floats(allow_nan=False, allow_infinity=False, width=64)


def test_keys_live_under_the_run_and_tokens_under_at() -> None:
    k = Keys("r-1")
    assert k.state(3) == "shoal/r-1/agent/3/state"
    assert k.command(3) == "shoal/r-1/agent/3/cmd"
    assert k.sensing(3) == "shoal/r-1/agent/3/sensing"
    assert k.everything == "shoal/r-1/**"
    assert k.alive_agent(3) == "@shoal/r-1/agent/3"
    assert agent_of(k.state(12)) == 12 and agent_of(k.alive_agent(7)) == 7
    assert agent_of(k.tick) is None and agent_of("shoal/r/agent/²/state") is None
    # only canonical ids: a cmd on agent/01/cmd must not pass for agent 1's
    assert agent_of("shoal/r/agent/01/cmd") is None and agent_of("shoal/r/agent/0/cmd") is None


@pytest.mark.parametrize("bad", ["", "a/b", "a b", "x*", "$", "é", "a" * 65])
def test_bad_run_ids_are_refused(bad: str) -> None:
    with pytest.raises(WireError, match="run id"):
        Keys(bad)


@pytest.mark.parametrize("name", builtin_names())
def test_every_agent_config_round_trips_exactly(name: str) -> None:
    s = load_scenario(name)
    for i in range(1, s.n + 1):
        c = s.agent_config(i)
        assert codec.decode_assignment(codec.encode_config(c, clock="realtime")) == (c, "realtime")


@given(pos=st.tuples(FLOATS, FLOATS), tick=st.integers(0, 2**40), bid=FLOATS, omega=st.booleans())
@settings(max_examples=200, deadline=None)
def test_states_and_reports_round_trip_bit_for_bit(
    pos: tuple[float, float], tick: int, bid: float, omega: bool
) -> None:
    s = AgentState(4, tick, pos, omega, bid, 2.0, -0.5)
    assert codec.decode_state(codec.encode_state(s)) == s
    c = Command(4, tick, (pos[1], pos[0]), filtered=omega)
    assert codec.decode_report(codec.encode_report(s, c)) == (s, c)


def test_sensing_tick_event_and_documents_round_trip() -> None:
    sensing = Sensing(5, (1.0, 2.0), (0, 3), ((4.0, 5.0), (6.0, 7.0)), (1.0, 0.5),
                      (2, 4), ((1.5, 2.0), (0.0, -1.0)))  # fmt: skip
    assert codec.decode_sensing(codec.encode_sensing(sensing)) == sensing
    rec = TickRecord(9, ((0.1, 0.2),) * 2, ((1.0, 0.0),) * 2, (False, True), (1.0, 4.0),
                     (1.0, 1.0), (0.0, 0.0), (True, False), (False, True))  # fmt: skip
    assert codec.decode_tick(codec.encode_tick(rec)) == rec
    ev = Event(3, 3, 2, "agent 2 gone")
    assert codec.decode_event(codec.encode_event(ev)) == ev
    doc = {"a": 1, "b": None, "c": "x", "d": 2.5}
    assert codec.decode_document("summary", codec.encode_document("summary", doc)) == doc


def _state(**change: Any) -> bytes:
    body = {"v": codec.SCHEMA, "k": "state", "id": 2, "tick": 5, "pos": [1.0, 2.0], "omega": False,
            "bid": 1.0, "sigma": 1.0, "theta": 0.0}  # fmt: skip
    body.update(change)
    return bytes(msgpack.packb({k: v for k, v in body.items() if v is not ...}))


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"\xc1", "not msgpack"),
        (msgpack.packb([1, 2]), "expected a map"),
        (_state(v=codec.SCHEMA + 1), f"schema version {codec.SCHEMA + 1}"),
        (_state(k="cmd"), "expected a state message"),
        (_state(id="two"), "state.id: expected an integer"),
        (_state(id=True), "state.id: expected an integer"),
        (_state(tick=...), "missing field 'tick'"),
        (_state(pos=[1.0]), "expected 2 or 3 coordinates"),
        (_state(pos=[math.nan, 0.0]), "not finite"),
        (_state(pos=[math.inf, 0.0]), "not finite"),
        (_state(bid="1"), "expected a number"),
        (_state(omega=0), "expected true/false"),
    ],
)
def test_every_kind_of_bad_state_is_a_decode_error(data: bytes, message: str) -> None:
    with pytest.raises(DecodeError, match=message):
        codec.decode_state(data)


def test_sensing_with_mismatched_obstacle_lists_is_refused() -> None:
    bad = codec.encode_sensing(Sensing(1, (0.0, 0.0), (0, 1), ((1.0, 1.0),), (1.0,)))
    with pytest.raises(DecodeError, match="differ in length"):
        codec.decode_sensing(bad)


def test_a_leaders_reach_travels_only_when_it_is_not_the_simulated_one() -> None:
    leader = load_scenario("default").agent_config(1)
    assert isinstance(leader.path, Waypoints) and leader.path.reach == REACHED
    assert b"reach" not in codec.encode_config(leader)  # simulated runs' bytes as before
    wide = dataclasses.replace(leader, path=dataclasses.replace(leader.path, reach=0.51))
    data = codec.encode_config(wide)
    assert b"reach" in data and codec.decode_config(data) == wide
    for bad in (0.0, -1.0, float("inf"), float("nan")):
        # No such configuration can be made (AgentConfig checks itself): a peer sends the bytes.
        assert data.count(struct.pack(">d", 0.51)) == 1
        broken = data.replace(struct.pack(">d", 0.51), struct.pack(">d", bad))
        with pytest.raises(DecodeError, match=r"config\.path\.reach"):
            codec.decode_config(broken)


def test_a_robots_record_round_trips_and_a_short_one_is_refused() -> None:
    r = RobotsRecord(7, ((0.2, 0.0, -0.5), (0.1, -0.1, 0.0)), (0.012, 0.003))
    assert codec.decode_robots(codec.encode_robots(r)) == r
    blind = RobotsRecord(7, r.twists)  # robots that cannot tell their poses' age
    assert b"age" not in codec.encode_robots(blind)
    assert codec.decode_robots(codec.encode_robots(blind)) == blind
    for bad in (RobotsRecord(7, ((0.1, 0.2, 0.3),), (0.0, 0.1)), RobotsRecord(7, ((0.1, 0.2),))):
        with pytest.raises(DecodeError, match="robots"):
            codec.decode_robots(codec.encode_robots(bad))


def test_unknown_clock_in_a_config_is_refused() -> None:
    data = codec.encode_config(load_scenario("default").agent_config(2), clock="sometimes")
    with pytest.raises(DecodeError, match=r"config\.clock"):
        codec.decode_assignment(data)


@given(st.binary(max_size=200))
@settings(max_examples=300, deadline=None)
def test_random_bytes_never_escape_as_another_error(data: bytes) -> None:
    for decode in (codec.decode_state, codec.decode_sensing, codec.decode_report,
                   codec.decode_tick, codec.decode_event, codec.decode_config,
                   codec.decode_robots):  # fmt: skip
        with pytest.raises(DecodeError):
            decode(data)


def test_zenoh_config_precedence(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ZENOH_CONFIG", raising=False)
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", 'connect/endpoints=["tcp/10.0.0.1:1"];mode="peer"')
    conf = zenoh_config(mode="client", connect=["tcp/127.0.0.1:7447"])
    assert conf.get_json("mode") == '"client"'  # explicit beats the override
    assert "127.0.0.1:7447" in conf.get_json("connect/endpoints")
    assert conf.get_json("scouting/multicast/enabled") == "false"
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", "connect/timeout_ms=1234")
    assert zenoh_config(mode="client").get_json("connect/timeout_ms") == "1234"
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", "not-a-pair")
    with pytest.raises(WireError, match="key=json5"):
        zenoh_config(mode="client")
    with pytest.raises(WireError, match="zenoh mode"):
        zenoh_config(mode="satellite")


def _doc_row(kind: str) -> str:
    wire = (Path(__file__).parents[2] / "docs" / "wire.md").read_text(encoding="utf-8")
    rows = [line for line in wire.splitlines() if line.startswith(f"| `{kind}` |")]
    assert len(rows) == 1, kind
    return rows[0]


@pytest.mark.parametrize(
    ("kind", "keys"),
    [*((k.kind, [f.key for f in k.table]) for cls, k in codec.KINDS.items() if cls is not Command),
     ("cmd", ["state", *(f.key for f in codec.COMMAND)])],  # "every `state` field" + its own
)  # fmt: skip
def test_the_docs_list_every_field_of_every_message_in_wire_order(kind: str, keys: Any) -> None:
    """docs/wire.md's field list follows the fields bus/messages.py declares: every key of
    every message the codec knows, in the order the encoder writes them."""
    row = _doc_row(kind)
    at = [row.find(f"`{key}`") for key in keys]
    assert -1 not in at and at == sorted(at), keys


def test_the_docs_list_every_control_parameter_a_config_carries() -> None:
    row = _doc_row("config")
    for name in (*(f.name for f in dataclasses.fields(ControlParams)),):
        assert f"`{name}`" in row, name
