"""Foxglove views: every exported message validates against Foxglove's own published JSON
schemas (npm @foxglove/schemas, fetched by .ci/foxglove-schemas: SHOAL_FOXGLOVE_SCHEMAS=<dir>),
the copy shoal ships equals them, and the views say what the tick records say.

The views' core is a pure function, so most tests feed it the reference simulator's ticks; a raw
log written with the logger's own writer stands in for a run in the export tests, and one short
real run (`integration`) checks the file `shoal run` leaves.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
from collections.abc import Iterator
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import json_of, run_cli
from jsonschema import Draft202012Validator
from jsonschema.validators import validator_for
from mcap.reader import make_reader
from runlogs import GONE_AT, TINY, TINY_3D, TINY_PEOPLE, raw_log, reference_log

from shoal.bus.messages import Event
from shoal.tools.cli import main
from shoal.tools.foxglove.export import export_beside, sibling
from shoal.tools.foxglove.msgs import arrow, dashes, vec3s
from shoal.tools.foxglove.plots import CLEARANCE, FILTER, FORMATION_ERROR, OMEGA, topics_of
from shoal.tools.foxglove.views import (
    AGENTS,
    FRAMES,
    GRAPH,
    LOG,
    SCHEMAS_VERSION,
    SENSING,
    TOPICS,
    TRAILS,
    WORLD,
    View,
    ViewOptions,
    every,
    schema_text,
    views,
)
from shoal.tools.log.writer import McapLog
from shoal.tools.simulator import simulate
from shoal.world.loader import load_scenario, parse_scenario
from shoal.world.metrics import summarize

ROOT = Path(__file__).resolve().parents[2]
VENDORED = ROOT / "tools" / "foxglove" / "schemas"


@pytest.fixture(scope="module")
def npm_schemas() -> Path:
    """The directory .ci/foxglove-schemas filled from npm (or its default cache)."""
    given = os.environ.get("SHOAL_FOXGLOVE_SCHEMAS")
    path = Path(given) if given else ROOT / ".cache" / "foxglove-schemas" / SCHEMAS_VERSION
    if (path / "SceneUpdate.json").is_file():
        return path
    if os.environ.get("SHOAL_REQUIRE_FOXGLOVE_SCHEMAS") == "1":
        pytest.fail(f"no Foxglove schemas in {path}: run .ci/foxglove-schemas")
    pytest.skip("Foxglove's schemas not fetched: SHOAL_FOXGLOVE_SCHEMAS=$(.ci/foxglove-schemas)")


class Validators:
    """A validator per schema name: Foxglove's from the npm package, shoal's own as the file
    carries them (checked to be valid schemas first)."""

    def __init__(self, npm: Path) -> None:
        self.npm = npm
        self.cache: dict[str, Any] = {}

    def __call__(self, name: str, schema_data: bytes | None = None) -> Any:
        if name not in self.cache:
            if name.startswith("foxglove."):
                path = self.npm / f"{name.removeprefix('foxglove.')}.json"
                schema = json.loads(path.read_text())
            else:
                schema = json.loads(schema_data if schema_data is not None else schema_text(name))
            cls = validator_for(schema, default=Draft202012Validator)
            cls.check_schema(schema)
            self.cache[name] = cls(schema)
        return self.cache[name]


def by_topic(msgs: list[View], topic: str) -> list[View]:
    return [v for v in msgs if v.topic == topic]


# -- the schemas ----------------------------------------------------------------------------


def test_the_shipped_schemas_are_the_npm_packages_own(npm_schemas: Path) -> None:
    shipped = sorted(VENDORED.glob("*.json"))
    assert {p.stem for p in shipped} == {n.removeprefix("foxglove.") for n in TOPICS.values()} - {
        n for n in TOPICS.values() if n.startswith("shoal.")
    }
    for path in shipped:
        assert json.loads(path.read_text()) == json.loads((npm_schemas / path.name).read_text())
        assert schema_text(f"foxglove.{path.stem}") == path.read_bytes()
    script = (ROOT / ".ci" / "foxglove-schemas").read_text()
    assert re.search(rf"^version={re.escape(SCHEMAS_VERSION)}$", script, re.M)
    assert SCHEMAS_VERSION in (VENDORED / "README.md").read_text()


def test_shoal_schemas_use_only_what_foxglove_decodes() -> None:
    """Foxglove's JSON decoder reads typed properties, arrays of numbers or objects; no null,
    no oneOf, no $ref (packages/mcap-support parseJsonSchema)."""

    def check(schema: dict[str, Any]) -> None:
        assert schema["type"] == "object" and set(schema["required"]) == set(schema["properties"])
        for field in schema["properties"].values():
            assert field["type"] in ("boolean", "string", "number", "integer", "object", "array")
            if field["type"] == "object":
                check(field)
            if field["type"] == "array":
                item = field["items"]
                assert item["type"] in ("number", "integer", "object")
                if item["type"] == "object":
                    check(item)

    for name in {n for n in TOPICS.values() if n.startswith("shoal.")}:
        schema = json.loads(schema_text(name))
        Draft202012Validator.check_schema(schema)
        assert schema["title"] == name
        check(schema)


# -- the pure core --------------------------------------------------------------------------


@pytest.mark.parametrize(("text", "gone"), [(TINY, GONE_AT), (TINY_3D, None)])
def test_every_view_validates_against_foxglove_schemas(
    npm_schemas: Path, text: str, gone: int | None
) -> None:
    validators = Validators(npm_schemas)
    # Every state (Ω, gone, reshaped) lasts many ticks: lower rates keep every kind of message
    # and halve the (slow) validation.
    msgs = list(views(reference_log(text, gone=gone), ViewOptions(scene_hz=10.0, plot_hz=20.0)))
    assert {v.topic for v in msgs} == set(TOPICS)
    for v in msgs:
        validators(TOPICS[v.topic]).validate(v.message)
        json.dumps(v.message, allow_nan=False)


def test_moving_obstacles_are_drawn_where_they_are_with_trails_and_validate(
    npm_schemas: Path,
) -> None:
    run = reference_log(TINY_PEOPLE)
    msgs = list(views(run, ViewOptions(scene_hz=10.0, plot_hz=20.0)))
    validators = Validators(npm_schemas)
    for v in msgs:
        validators(TOPICS[v.topic]).validate(v.message)
    (world,) = by_topic(msgs, WORLD)
    assert [e["id"] for e in world.message["entities"] if e["id"].startswith("obstacle/")] == [
        "obstacle/0"
    ]  # only the standing one is drawn once
    last = by_topic(msgs, AGENTS)[-1].message
    movers = {e["id"]: e for e in last["entities"] if e["id"].startswith("mover/")}
    assert set(movers) == {"mover/1", "mover/2"}
    final = run.ticks[-1][1]
    for k, centre in zip((1, 2), final.mover_centres, strict=True):
        pillar = movers[f"mover/{k}"]["cylinders"][0]["pose"]["position"]
        assert (pillar["x"], pillar["y"]) == pytest.approx(centre, abs=1e-4)  # views round
    trails = {e["id"] for e in by_topic(msgs, TRAILS)[-1].message["entities"]}
    assert {"trail/mover/1", "trail/mover/2"} <= trails


def test_views_are_stamped_with_the_log_time_of_their_record() -> None:
    run = reference_log(TINY, gone=GONE_AT)
    msgs = list(views(run))
    times = [v.ns for v in msgs]
    assert times == sorted(times)
    allowed = {run.start_ns} | {ns for ns, _r in run.ticks} | {ns for ns, _e in run.events}
    assert set(times) <= allowed
    records = dict(run.ticks)
    for v in msgs:
        if TOPICS[v.topic].startswith("shoal."):  # the scalar channels: tick and t, no stamp
            assert v.message["tick"] == records[v.ns].tick
            continue
        stamps = list(_stamps(v.message))
        assert stamps and all(s == {"sec": v.ns // 10**9, "nsec": v.ns % 10**9} for s in stamps)
    assert [v.ns for v in by_topic(msgs, WORLD)] == [run.start_ns]
    assert [v.ns for v in by_topic(msgs, SENSING)] == [run.ticks[0][0]]


def _stamps(message: Any) -> Iterator[Any]:
    """Every foxglove ``timestamp`` in a message, at any depth."""
    if isinstance(message, dict):
        for key, value in message.items():
            if key == "timestamp":
                yield value
            else:
                yield from _stamps(value)
    elif isinstance(message, list):
        for item in message:
            yield from _stamps(item)


def test_scene_and_plots_are_decimated_in_simulated_time() -> None:
    run = reference_log(TINY)
    s = run.scenario
    msgs = list(views(run, ViewOptions(scene_hz=10.0, plot_hz=25.0)))
    scene, plot = every(10.0, s.dt), every(25.0, s.dt)
    assert (scene, plot) == (5, 2)
    last = s.steps - 1
    drawn = sorted({0, last} | set(range(0, s.steps, scene)))
    assert [v.message["entities"][0]["timestamp"] for v in by_topic(msgs, AGENTS)] == [
        {"sec": ns // 10**9, "nsec": ns % 10**9} for ns, _r in (run.ticks[k] for k in drawn)
    ]
    assert len(by_topic(msgs, FRAMES)) == len(drawn)
    ticks = [v.message["tick"] for v in by_topic(msgs, OMEGA)]
    assert ticks == sorted({last} | set(range(0, s.steps, plot)))
    assert [v.message["t"] for v in by_topic(msgs, OMEGA)] == [round(k * s.dt, 6) for k in ticks]


def test_metrics_are_the_summarys() -> None:
    run = reference_log(TINY)
    s = run.scenario
    summary = summarize(s, simulate(s))
    msgs = list(views(run))
    errors = by_topic(msgs, FORMATION_ERROR)
    assert len(errors) == s.steps
    assert errors[-1].message["value"] == pytest.approx(summary.final_formation_error, abs=1e-6)
    clearance = [v.message["value"] for v in by_topic(msgs, CLEARANCE)]
    assert summary.min_clearance is not None
    assert min(clearance) == pytest.approx(summary.min_clearance, abs=2e-3)  # + last Euler step
    assert min(clearance) >= summary.min_clearance - 1e-6
    omega = by_topic(msgs, OMEGA)
    for v, (_ns, r) in zip(omega, run.ticks, strict=True):
        assert [a["value"] for a in v.message["agents"]] == [int(w) for w in r.omega]
        assert v.message["value"] == sum(r.omega)


def test_filter_activity_is_the_logs_filtered_flags() -> None:
    """crossing: people walk at the formation, and the safety filter changes commands."""
    scenario = load_scenario("crossing")
    run = reference_log(scenario.source)
    s = run.scenario
    summary = summarize(s, simulate(s))
    acting = by_topic(list(views(run)), FILTER)
    assert len(acting) == s.steps == 800  # dt 0.05 s: every tick
    total = 0
    for v, (ns, r) in zip(acting, run.ticks, strict=True):
        m = v.message
        assert (v.ns, m["tick"]) == (ns, r.tick)
        assert [a["value"] for a in m["agents"]] == [int(f) for f in r.filtered]
        assert [a["id"] for a in m["agents"]] == [1, 2, 3, 4, 5]
        assert m["value"] == sum(r.filtered) and m["fraction"] == round(sum(r.filtered) / 5, 6)
        total += m["value"]
    flags = np.array([r.filtered for _ns, r in run.ticks])
    assert total == int(flags.sum()) == round(summary.filter_activity * s.n * s.steps) > 100
    assert np.mean([v.message["fraction"] for v in acting]) == pytest.approx(
        summary.filter_activity, abs=1e-9
    )
    acted = {a["id"] for v in acting for a in v.message["agents"] if a["value"]}
    assert acted == {1, 2, 3, 4, 5}
    assert sum(v.message["value"] > 0 for v in acting) == int(flags.any(axis=1).sum()) > 50


def test_without_the_filter_there_is_no_filter_channel() -> None:
    paper = TINY + "control:\n  safety: paper\n"
    run = reference_log(paper)
    assert FILTER not in topics_of(run.scenario) and FILTER in topics_of(parse_scenario(TINY))
    topics = {v.topic for v in views(replace(run, ticks=run.ticks[:5]))}
    assert topics == set(TOPICS) - {FILTER}


def test_dropped_edges_follow_omega_and_departures() -> None:
    run = reference_log(TINY, gone=GONE_AT)
    records = dict(run.ticks)
    seen = set()
    for v in by_topic(list(views(run)), GRAPH):
        r = records[v.ns]
        groups = {e["id"]: e["metadata"][0]["value"] for e in v.message["entities"]}
        expected_dropped = "2-3 (agent 2 evades), 2-4 (agent 2 evades)" if r.omega[1] else ""
        if r.tick >= GONE_AT:  # 2 and 3 sense agent 4, which is gone (the leader senses none)
            expected_gone = "2-4 (agent 4 gone), 3-4 (agent 4 gone)"
            expected_dropped = "2-3 (agent 2 evades)" if r.omega[1] else ""
        else:
            expected_gone = ""
        assert groups["edges/dropped"] == expected_dropped, r.tick
        assert groups["edges/gone"] == expected_gone, r.tick
        assert "1-2" in groups["edges/followed"]  # the leader's side never counts
        seen.add((bool(expected_dropped), bool(expected_gone)))
    assert seen == {(False, False), (True, False), (True, True), (False, True)}


def test_the_log_has_the_worlds_events_and_the_changes_it_derives() -> None:
    run = reference_log(TINY, gone=GONE_AT)
    logs = [v.message for v in by_topic(list(views(run)), LOG)]
    lines = [(m["level"], m["name"], m["message"]) for m in logs]
    assert (
        3,
        "agent 4",
        f"tick {GONE_AT}: agent 4 gone at tick {GONE_AT}; held still from now on",
    ) in lines
    assert lines[-1] == (2, "world", "tick 200: run finished; 0 bad messages dropped")
    starts = [n for lvl, n, text in lines if "starts evading" in text]
    stops = [n for lvl, n, text in lines if "stops evading" in text]
    assert starts == ["agent 2"] and stops == ["agent 2"]
    assert any("largest σ applied 1 → 1.5" in text for _l, _n, text in lines)


def test_a_level_foxglove_does_not_know_is_logged_as_unknown() -> None:
    run = reference_log(TINY)
    odd = replace(run, ticks=run.ticks[:2], events=[(run.ticks[0][0], Event(0, 9, 0, "odd"))])
    logs = [v.message for v in views(odd) if v.topic == LOG]
    assert [(m["level"], m["message"]) for m in logs] == [(0, "tick 0: odd")]


def test_agents_carry_their_state_and_the_slots_their_error() -> None:
    run = reference_log(TINY, gone=GONE_AT)
    records = dict(run.ticks)
    for v in by_topic(list(views(run)), AGENTS):
        r = records[v.ns]
        ids = [e["id"] for e in v.message["entities"]]
        assert ids == ["agent/1", "agent/2", "agent/3", "agent/4", "slots"]
        for i, e in enumerate(v.message["entities"][:4]):
            meta = {m["key"]: m["value"] for m in e["metadata"]}
            assert meta["omega"] == str(r.omega[i]).lower()
            assert meta["alive"] == str(r.alive[i]).lower()
            label = e["texts"][0]["text"]
            assert ("Ω" in label) == r.omega[i] and ("gone" in label) == (not r.alive[i])
            assert e["spheres"][0]["size"]["x"] == 2 * run.scenario.agent_radius
        crosses, errors = v.message["entities"][4]["lines"]
        assert len(crosses["points"]) == 4 * 3 and len(errors["points"]) == 2 * 3


def test_unicycles_are_drawn_with_the_body_behind_the_point_and_face_their_heading(
    npm_schemas: Path,
) -> None:
    """A unicycle's frame turns with its heading; its body is drawn about the axle, l behind
    the point the laws move, with an arrow along the heading; every view still validates."""
    text = resources.files("shoal.world.scenarios").joinpath("robotarium.yaml").read_text()
    run = reference_log(text.replace("duration: 75.0", "duration: 10.0"))
    s, ell = run.scenario, run.scenario.lookahead or 0.0
    msgs = list(views(run, ViewOptions(scene_hz=1.0, plot_hz=1.0)))
    validators = Validators(npm_schemas)
    for v in msgs:
        validators(TOPICS[v.topic]).validate(v.message)
    records = dict(run.ticks)
    frames, agents = by_topic(msgs, FRAMES)[-1], by_topic(msgs, AGENTS)[-1]
    r = records[frames.ns]
    assert agents.ns == frames.ns and len(r.headings) == s.n
    for i, theta in enumerate(r.headings):
        e = np.array([math.cos(theta), math.sin(theta), 0.0])
        q = frames.message["transforms"][i]["rotation"]
        assert _rotate(q, np.array([1.0, 0.0, 0.0])) == pytest.approx(e, abs=1e-9)
        agent = agents.message["entities"][i]
        body, dot = agent["spheres"]
        centre = np.array([body["pose"]["position"][k] for k in "xyz"])
        assert centre == pytest.approx(np.array([*r.positions[i], 0.0]) - ell * e, abs=1e-4)
        assert body["size"]["x"] == 2 * s.agent_radius and dot["size"]["x"] < body["size"]["x"]
        heading = agent["arrows"][-1]
        along = _rotate(heading["pose"]["orientation"], np.array([1.0, 0.0, 0.0]))
        assert along == pytest.approx(e, abs=1e-4)
        meta = {m["key"]: m["value"] for m in agent["metadata"]}
        assert float(meta["heading_rad"]) == pytest.approx(theta, rel=1e-5)


def test_arrows_point_along_their_vector() -> None:
    for vector in [(1.0, 0.0), (0.0, 2.0), (-3.0, 0.0), (1.0, -1.0, 0.5), (0.0, 0.0, -1.0)]:
        a = arrow({"x": 0.0, "y": 0.0, "z": 0.0}, vector, (1, 1, 1, 1), 0.05)
        assert a is not None
        q = a["pose"]["orientation"]
        v = np.array([*vector, 0.0][:3])
        along = _rotate(q, np.array([1.0, 0.0, 0.0]))
        assert along == pytest.approx(v / np.linalg.norm(v), abs=1e-5)
        assert a["shaft_length"] + a["head_length"] == pytest.approx(np.linalg.norm(v), abs=1e-4)
    assert arrow({"x": 0.0, "y": 0.0, "z": 0.0}, (0.0, 0.0), (1, 1, 1, 1), 0.05) is None


def _rotate(q: dict[str, float], v: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
    u, w = np.array([q["x"], q["y"], q["z"]]), q["w"]
    return np.asarray(v + 2 * np.cross(u, np.cross(u, v) + w * v))


def test_dashes_and_points() -> None:
    a, b = {"x": 0.0, "y": 0.0, "z": 0.0}, {"x": 12.0, "y": 0.0, "z": 0.0}
    d = dashes(a, b)
    assert len(d) == 24 and d[0] == a and d[1]["x"] == 0.5 and d[-1]["x"] == 11.5
    assert vec3s([(1.23456, 2.0)]) == [{"x": 1.2346, "y": 2.0, "z": 0.0}]
    assert sibling(Path("runs/a-1.mcap")) == Path("runs/a-1.foxglove.mcap")
    assert sibling(Path("log.bin")) == Path("log.bin.foxglove.mcap")


# -- export: MCAP in, MCAP out ----------------------------------------------------------------


def check_views_file(path: Path, validators: Validators) -> dict[str, int]:
    """Every channel is Foxglove JSON with its schema; every message validates. Returns the
    message count per topic."""
    counts: dict[str, int] = {}
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
            assert schema.name == TOPICS[channel.topic]
            assert schema.data == schema_text(schema.name)
        for schema, channel, message in reader.iter_messages():
            assert schema is not None
            validators(schema.name, schema.data).validate(json.loads(message.data))
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
        names = [m.name for m in reader.iter_metadata()]
        assert names == ["scenario", "summary", "foxglove"]
        assert [a.name for a in reader.iter_attachments()] == ["scenario.yaml"]
    return counts


def test_export_writes_views_beside_the_log_and_never_touches_it(
    npm_schemas: Path, tmp_path: Path
) -> None:
    run = reference_log(TINY, gone=GONE_AT)
    raw = tmp_path / "tiny-fox-1.mcap"
    raw_log(raw, run)
    before = hashlib.sha256(raw.read_bytes()).hexdigest()
    done = CliRunner().invoke(main, ["export", str(raw), "--json", "--scene-hz", "5"])
    assert done.exit_code == 0, done.output
    out = json.loads(done.output)
    assert out["out"] == str(tmp_path / "tiny-fox-1.foxglove.mcap") == str(sibling(raw))
    assert hashlib.sha256(raw.read_bytes()).hexdigest() == before
    counts = check_views_file(sibling(raw), Validators(npm_schemas))
    assert set(counts) == set(TOPICS) and sum(counts.values()) == out["messages"]
    assert counts[FORMATION_ERROR] == out["ticks"] == 200
    with sibling(raw).open("rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert meta["scenario"]["run"] == "fox-1" and meta["summary"]["clock"] == "lockstep"
    assert meta["foxglove"]["schemas"] == f"@foxglove/schemas {SCHEMAS_VERSION}"
    assert list(tmp_path.glob("*.part")) == []

    again = CliRunner().invoke(main, ["export", str(raw), "-o", str(tmp_path / "x.mcap")])
    assert again.exit_code == 0 and "200 tick records" in again.output


def test_export_refuses_what_it_cannot_do_and_leaves_nothing_behind(tmp_path: Path) -> None:
    raw = tmp_path / "run.mcap"
    raw_log(raw, reference_log(TINY))
    same = CliRunner().invoke(main, ["export", str(raw), "-o", str(raw)])
    assert same.exit_code != 0 and "another file" in same.output
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(raw.read_bytes()[: raw.stat().st_size // 2])
    broken = CliRunner().invoke(main, ["export", str(cut)])
    assert broken.exit_code != 0 and "shoal recover" in broken.output
    empty = tmp_path / "empty.mcap"
    with McapLog(empty, run="x"):
        pass
    nothing = CliRunner().invoke(main, ["export", str(empty)])
    assert nothing.exit_code != 0 and "no scenario" in nothing.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.mcap", "empty.mcap", "run.mcap"]


def test_a_failed_export_after_a_run_is_a_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    empty = tmp_path / "run.mcap"
    with McapLog(empty, run="x"):
        pass
    assert export_beside(empty, progress=False) is None
    assert "no Foxglove views" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]


def test_a_run_without_obstacles_has_no_clearance_channel() -> None:
    text = TINY.split("obstacles:")[0]
    run = reference_log(text)
    assert CLEARANCE not in {v.topic for v in views(run)}
    world = next(v for v in views(replace(run, ticks=run.ticks[:3])) if v.topic == WORLD)
    assert [e["id"] for e in world.message["entities"]] == ["path"]


# -- a real run -----------------------------------------------------------------------------


@pytest.mark.integration
def test_shoal_run_leaves_a_views_file_that_foxglove_reads(
    npm_schemas: Path, tmp_path: Path
) -> None:
    scenario = tmp_path / "tiny.yaml"
    scenario.write_text(TINY)
    log = tmp_path / "run.mcap"
    proc = run_cli(["run", str(scenario), "--json", "--out", str(log)])
    assert proc.returncode == 0
    got = json_of(proc)
    assert got["foxglove"] == str(sibling(log))
    counts = check_views_file(sibling(log), Validators(npm_schemas))
    assert counts[FORMATION_ERROR] == 200 and counts[WORLD] == counts[SENSING] == 1
    with log.open("rb") as f:  # the raw log is the logger's alone
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert {c.message_encoding for c in summary.channels.values()} == {"msgpack"}
