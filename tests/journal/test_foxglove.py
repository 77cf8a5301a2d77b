"""Tests that journals open well in Foxglove: metadata, attachments,
derived channels (profiles, levels, log) and the shipped layout."""

from __future__ import annotations

import json
import re
from typing import TYPE_CHECKING

import msgspec
import pytest
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import Writer

from fsw_scheduler.app.demo import failure_scenario, run_demo
from fsw_scheduler.journal.annotate import (
    LOG_SCHEMA,
    Annotator,
    schema_lookup,
)
from fsw_scheduler.journal.channels import channel_spec, live_channels
from fsw_scheduler.journal.info import info, info_dict
from fsw_scheduler.journal.replay import verify
from fsw_scheduler.model.plan import Activity, SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.wire.messages import PlanMessage, ResourceLevel
from fsw_scheduler.wire.profiles import level_check, plan_profiles
from fsw_scheduler.wire.topics import PROFILES, RESOURCE_LEVELS, Topics

from ..factories import ROOT

if TYPE_CHECKING:
    from pathlib import Path

    from fsw_scheduler.testing import SchedulerHarness

pytest_plugins = ["fsw_scheduler.testing"]

LAYOUT = ROOT / "docs" / "foxglove-layout.json"
#: A Foxglove message path: quoted topic, optional filter, fields.
PATH = re.compile(r'"([^"]+)"(\{[^}]*\})?((?:\.\w+|\[:\])*)')
TOPICS = Topics()
PROFILES_TOPIC = TOPICS.key(PROFILES)
PROBLEM = decode_problem(
    json.dumps(
        {
            "horizon": 6,
            "start": 10,
            "resources": {"consumable": {"battery": 10}},
            "tasks": [
                {
                    "id": "use",
                    "length": 2,
                    "delay_cost": 1,
                    "schedule_cost": 1,
                    "uses": {"battery": 3},
                },
                {
                    "id": "charge",
                    "length": 2,
                    "delay_cost": 1,
                    "schedule_cost": 1,
                    "uses": {"battery": -1},
                },
            ],
        }
    )
)
PLAN = PlanMessage(
    plan_id=4,
    issued_at=10,
    horizon_start=10,
    horizon_end=16,
    status=SolveStatus.OPTIMAL,
    objective=None,
    activities=(Activity("use", 10, 12), Activity("charge", 13, 15)),
)


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh journal of the failure scenario (plans, drift, a failure)."""
    out = tmp_path_factory.mktemp("session")
    return run_demo(
        out,
        scenario=failure_scenario(),
        quiet=True,
        pictures=False,
        verify=False,
    ).journal


def _read(path: Path) -> tuple[dict, dict, list]:
    """Metadata, attachments and (schema, channel, message) with mcap."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        attachments = {a.name: a for a in reader.iter_attachments()}
        messages = list(reader.iter_messages(log_time_order=True))
    return metadata, attachments, messages


def test_plan_profiles_are_levels_at_unit_starts() -> None:
    """Tests the predicted levels: initial first, then after each unit."""
    profiles = plan_profiles(PROBLEM, PLAN)
    assert profiles.plan_id == 4 and profiles.issued_at == 10
    assert profiles.times == tuple(range(10, 17))
    assert profiles.levels == {"battery": (10.0, 7.0, 4.0, 4.0, 5.0, 6.0, 6.0)}
    assert profiles.level_at("battery", 12) == 4.0
    assert profiles.level_at("battery", 17) is None
    assert profiles.level_at("propellant", 12) is None


def test_level_check_sets_measured_beside_predicted() -> None:
    """Tests a measured level against the plan in force, or none."""
    profiles = plan_profiles(PROBLEM, PLAN)
    check = level_check(profiles, ResourceLevel("battery", 3.5, 12))
    assert (check.predicted, check.departure, check.plan_id) == (4.0, -0.5, 4)
    early = level_check(None, ResourceLevel("battery", 3.5, 12))
    assert early.predicted is None and early.plan_id is None


def test_annotator_ignores_what_it_cannot_decode() -> None:
    """Tests that malformed inputs derive nothing (the engine reports)."""
    annotator = Annotator(TOPICS)
    assert annotator.observe(TOPICS.resource_level("battery"), b"{") == []
    assert annotator.observe(TOPICS.key("clock"), b'{"now": 3}') == []


def test_journal_has_metadata_and_attachments(session: Path) -> None:
    """Tests the session metadata and attachments, read by mcap."""
    metadata, attachments, _ = _read(session)
    assert set(metadata) == {
        "fsw_scheduler.session",
        "fsw_scheduler.settings",
        "fsw_scheduler.versions",
    }
    meta = metadata["fsw_scheduler.session"]
    assert meta["spacecraft"] == "sat1" and meta["clock"] == "bus"
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT[\d:.]+Z", meta["start_time"])
    assert metadata["fsw_scheduler.settings"]["drift-absolute"] == "1.5"
    versions = metadata["fsw_scheduler.versions"]
    assert {"python", "fsw-scheduler", "msgspec", "mcap"} <= set(versions)
    problem = decode_problem(attachments["problem.json"].data)
    assert problem.num_tasks == 9
    assert attachments["problem.json"].media_type == "application/json"
    settings = attachments["settings.toml"].data.decode()
    assert 'spacecraft = "sat1"' in settings
    import tomllib

    assert tomllib.loads(settings)["drift-absolute"] == 1.5


def test_journal_has_derived_channels(session: Path) -> None:
    """Tests profiles, level checks and foxglove.Log entries read back."""
    _, _, messages = _read(session)
    by_kind: dict[str, list] = {}
    for schema, channel, message in messages:
        kind = TOPICS.schema_kind(channel.topic)
        by_kind.setdefault(kind or "", []).append((schema, channel, message))
    plans = [json.loads(m.data) for _, _, m in by_kind["plan"]]
    profiles = [json.loads(m.data) for _, _, m in by_kind["profiles"]]
    assert [p["plan_id"] for p in profiles] == [p["plan_id"] for p in plans]
    for plan, profile in zip(plans, profiles, strict=True):
        assert profile["times"][0] == plan["horizon_start"]
        assert profile["times"][-1] == plan["horizon_end"]
        assert set(profile["levels"]) == {"battery", "propellant"}
    # Each level report is followed by its check.
    levels = by_kind["resource_level"]
    checks = [json.loads(m.data) for _, _, m in by_kind["level_check"]]
    assert len(checks) == len(levels)
    assert any(c["departure"] and c["departure"] < 0 for c in checks)
    # foxglove.Log, with the well-known schema.
    schema, channel, _ = by_kind["log"][0]
    assert schema.name == "foxglove.Log"
    assert schema.encoding == SchemaEncoding.JSONSchema
    assert json.loads(schema.data) == json.loads(json.dumps(LOG_SCHEMA))
    assert channel.message_encoding == MessageEncoding.JSON
    entries = [json.loads(m.data) for _, _, m in by_kind["log"]]
    required = set(LOG_SCHEMA["required"])
    assert all(required <= set(e) for e in entries)
    assert all(e["level"] in range(6) for e in entries)
    texts = "\n".join(e["message"] for e in entries)
    assert "plan 1 (initial" in texts
    assert "DownlinkSat2Ground failed" in texts
    assert any(e["level"] == 3 and "drift" in e["message"] for e in entries)


def test_existing_channels_unchanged(session: Path) -> None:
    """Tests that the earlier channels keep their schemas and encoding."""
    _, _, messages = _read(session)
    names = {ch.topic: s.name for s, ch, _ in messages if s is not None}
    assert names["fsw/sat1/scheduler/plan"] == "fsw_scheduler.plan"
    assert names["fsw/sat1/clock"] == "fsw_scheduler.clock"
    assert all(ch.message_encoding == "json" for _, ch, _ in messages)


def test_verify_checks_the_derived_channels(
    session: Path, tmp_path: Path
) -> None:
    """Tests that verify compares derived channels and catches a change."""
    report = verify(session)
    assert report.identical, report.summary()
    assert report.derived > 0
    with open(session, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        rows = list(reader.iter_messages(log_time_order=True))
    altered = tmp_path / "altered.mcap"
    changed = False
    with open(altered, "wb") as f:
        writer = Writer(f)
        writer.start()
        schema_ids = {
            sid: writer.register_schema(s.name, s.encoding, s.data)
            for sid, s in summary.schemas.items()
        }
        channel_ids = {
            cid: writer.register_channel(
                c.topic, c.message_encoding, schema_ids.get(c.schema_id, 0)
            )
            for cid, c in summary.channels.items()
        }
        for _s, channel, message in rows:
            data = message.data
            if not changed and channel.topic.endswith("/scheduler/profiles"):
                doc = json.loads(data)
                doc["levels"]["battery"][3] += 1
                data = json.dumps(doc).encode()
                changed = True
            writer.add_message(
                channel_ids[channel.id],
                message.log_time,
                data,
                message.publish_time,
            )
        writer.finish()
    report = verify(altered)
    assert not report.identical
    assert report.divergence is not None
    assert report.divergence.key_recorded == "fsw/sat1/scheduler/profiles"
    assert report.divergence.field == "levels.battery[3]"


def test_info_json_has_metadata(session: Path) -> None:
    """Tests the machine-readable description of a journal."""
    data = info_dict(info(session))
    json.dumps(data)
    assert data["metadata"]["fsw_scheduler.session"]["spacecraft"] == "sat1"
    assert {a["name"] for a in data["attachments"]} == {
        "problem.json",
        "settings.toml",
    }
    topics = {c["topic"]: c for c in data["channels"]}
    assert topics["fsw/sat1/scheduler/log"]["schema"] == "foxglove.Log"
    assert data["messages"] == sum(c["messages"] for c in data["channels"])
    assert data["end_ns"] >= data["start_ns"] > 0


def _paths(node: object) -> list[str]:
    """Every message path string in a layout config."""
    found: list[str] = []
    if isinstance(node, dict):
        for key, value in node.items():
            if key in ("value", "topicPath", "topicToRender") and isinstance(
                value, str
            ):
                found.append(value)
            else:
                found += _paths(value)
    elif isinstance(node, list):
        for value in node:
            found += _paths(value)
    return found


def test_layout_names_recorded_topics_and_fields(session: Path) -> None:
    """Tests that the layout's panels point at what a journal holds."""
    layout = json.loads(LAYOUT.read_text())
    panels = set(layout["configById"])
    assert {p.split("!")[0] for p in panels} >= {
        "Plot",
        "StateTransitions",
        "RosOut",
    }

    def leaves(tree: object) -> set[str]:
        if isinstance(tree, str):
            return {tree}
        assert isinstance(tree, dict)
        return leaves(tree["first"]) | leaves(tree["second"])

    assert leaves(layout["layout"]) == panels
    _, _, messages = _read(session)
    docs: dict[str, object] = {}
    for _s, channel, message in messages:
        docs.setdefault(channel.topic, json.loads(message.data))
    status_tasks: set[str] = set()
    for _s, channel, message in messages:
        if channel.topic.endswith("/scheduler/status"):
            status = json.loads(message.data)
            status_tasks |= set(status.get("activities", {}))
            status_tasks |= set(status.get("changed", {}))
    for path in _paths(layout["configById"]):
        match = PATH.fullmatch(path)
        topic = match.group(1) if match else path
        assert topic in docs, f"{path}: no topic {topic} in the journal"
        if not match:
            continue
        node = docs[topic]
        for part in re.findall(r"\.(\w+)", match.group(3)):
            if topic.endswith("/scheduler/status") and part in status_tasks:
                break
            assert isinstance(node, dict) and part in node, path
            node = node[part]


def test_log_schema_is_foxgloves() -> None:
    """Tests the foxglove.Log schema's name and required fields."""
    assert LOG_SCHEMA["title"] == "foxglove.Log"
    assert LOG_SCHEMA["required"] == [
        "timestamp",
        "level",
        "message",
        "name",
        "file",
        "line",
    ]
    levels = LOG_SCHEMA["properties"]["level"]["oneOf"]
    assert [lv["const"] for lv in levels] == list(range(6))
    msgspec.json.encode(LOG_SCHEMA)


def test_node_publishes_profiles_with_each_plan(
    scheduler_harness: SchedulerHarness,
) -> None:
    """Tests scheduler/profiles on the bus, right after each plan."""
    from fsw_scheduler.bus.session import wait_until

    h = scheduler_harness
    h.tick(0)
    plan = h.wait_plan(lambda p: p.plan_id == 1)
    key = h.topics.key("scheduler/profiles")

    def profiles() -> list[dict]:
        return [json.loads(p) for k, p in list(h.samples) if k == key]

    wait_until(lambda: bool(profiles()), 10.0, what="profiles")
    (first,) = profiles()
    assert first["plan_id"] == plan.plan_id
    assert first["times"][0] == plan.horizon_start
    assert first["times"][-1] == plan.horizon_end
    assert set(first["levels"]) == {"battery", "propellant"}
    seen = [k for k, _ in list(h.samples)]
    assert seen.index(key) > seen.index(h.topics.key("scheduler/plan"))


def test_layout_topics_are_journal_and_live_channels(session: Path) -> None:
    """Tests that every topic the layout names is a channel of the journal
    and of the live view, with the same schema name and text in both, and
    that no Plot panel accumulates every plan or has a key Plot lacks."""
    layout = json.loads(LAYOUT.read_text())
    _, _, messages = _read(session)
    journal = {ch.topic: (s, ch) for s, ch, _ in messages}
    live = {spec.topic: spec for spec in live_channels(TOPICS.spacecraft)}
    lookup = schema_lookup(TOPICS.spacecraft)
    named = TOPICS.key(RESOURCE_LEVELS) + "/"
    for path in _paths(layout["configById"]):
        match = PATH.fullmatch(path)
        topic = match.group(1) if match else path
        assert topic in journal, f"{path}: no {topic} in the journal"
        # A resource's channel is declared once the profiles name it
        # (tests/app/test_live_view.py); the fixed ones up front.
        spec = live.get(topic)
        if spec is None:
            assert topic.startswith(named), f"{topic}: not a live channel"
            spec = channel_spec(topic, lookup)
        schema, channel = journal[topic]
        assert channel.message_encoding == spec.message_encoding == "json"
        assert schema is not None and schema.name == spec.schema_name
        assert schema.encoding == spec.schema_encoding == "jsonschema"
        assert schema.data == spec.schema
    plots = {
        name: config
        for name, config in layout["configById"].items()
        if name.startswith("Plot!")
    }
    assert plots
    for name, config in plots.items():
        assert config.get("xAxisVal") != "custom", name
        assert "timeRange" not in config, name
    profile = plots["Plot!profile"]
    assert profile["xAxisVal"] == "currentCustom"
    assert PROFILES_TOPIC in profile["xAxisPath"]["value"]


def test_every_dispatch_is_on_one_channel(session: Path) -> None:
    """Tests a fresh journal: one ``scheduler/dispatch`` channel holds
    every dispatch, each naming its task (no channel per task), and the
    journal verifies."""
    _, _, messages = _read(session)
    root = TOPICS.key("scheduler/dispatch")
    topics = {ch.topic for _s, ch, _m in messages}
    assert not [t for t in topics if t.startswith(root + "/")]
    dispatched = [
        json.loads(m.data)["task"]
        for _s, ch, m in messages
        if ch.topic == root
    ]
    assert len(set(dispatched)) > 3, dispatched
    assert verify(session).identical


def test_the_layout_names_no_task() -> None:
    """Tests that the layout works for any task names: none of the
    scenarios' tasks is named in it (the state-transition panel follows
    the scheduler's state, events, plan and dispatched task)."""
    text = LAYOUT.read_text()
    tasks = {
        task["id"]
        for path in (ROOT / "fsw_scheduler" / "data").glob("*.json")
        for task in json.loads(path.read_text()).get("tasks", [])
    }
    assert len(tasks) > 10
    assert not [task for task in tasks if task in text]
    assert r"\"fsw/sat1/scheduler/dispatch\".task" in text
