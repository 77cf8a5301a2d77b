"""Tests of the settings mapping: node settings to the journal and back."""

from __future__ import annotations

import msgspec

from fsw_scheduler.journal.annotate import session_records
from fsw_scheduler.runtime.config import NodeConfig
from fsw_scheduler.runtime.policy import (
    IN_METADATA,
    config_from_info,
    node_info,
)
from fsw_scheduler.wire import messages

from ..factories import make_task, problem_from

#: Settings that decide nothing a replay re-runs: each with its reason.
NOT_REPLAYED = {
    "horizon": "applied to the problem, which node_info records",
    "time_unit": "a wall-clock node journals its ticks; replay reads them",
    "clock_stall": "a detected stall is journaled as an input",
    "inbox_capacity": "a goal refused unread is journaled (scheduler/busy)",
    "inbox_bytes": "goals and telemetry refused unread are journaled "
    "(scheduler/busy, scheduler/dropped, which carries the limit)",
    "discovery": "how the node finds its bus, not what it decides",
    "rank": "redundancy: which node commands, not what it decides",
    "standby": "redundancy: which node commands, not what it decides",
}

UNUSUAL = NodeConfig(
    spacecraft="sat7",
    solver="highs",
    time_limit=3.5,
    seed=11,
    threads=3,
    explain=False,
    explain_budget=0.5,
    clock="wall",
    report_timeout=9,
    drift_absolute=0.25,
    drift_relative=0.125,
    heartbeat=4,
    replan_lead=2,
    tasks_per_goal=7,
    live_tasks=70,
    goals_waiting=5,
    goals_per_solve=3,
    max_clock_step=50,
    node_id="b",
    explain_after_plan=True,
    response_deadline=1.5,
    commit_window=6,
    stability="lexicographic",
    move_cost=9,
    early_completion_gain=3,
    late_completion="push",
)


def test_every_setting_is_recorded_or_says_why_not() -> None:
    """Tests that each NodeConfig field is in NodeInfo, in the journal's
    settings metadata, or listed with the reason replay does not need it."""
    info = set(messages.NodeInfo.__struct_fields__) | {"time_limit"}
    for name in NodeConfig.__struct_fields__:
        assert name in info or name in IN_METADATA or name in NOT_REPLAYED, (
            f"{name}: record it in the journal or say why replay needs it not"
        )


def test_settings_survive_the_journal() -> None:
    """Tests node settings -> scheduler/config + settings metadata ->
    the same settings back, threads included."""
    problem = problem_from({"horizon": 10, "tasks": [make_task()]})
    info = node_info(UNUSUAL, problem)
    decoded = msgspec.json.decode(messages.encode(info), type=type(info))
    metadata = dict(session_records(UNUSUAL, problem, 0)[0])
    back = config_from_info(decoded, metadata["fsw_scheduler.settings"])
    replayed = {
        name: getattr(back, name)
        for name in NodeConfig.__struct_fields__
        if name not in NOT_REPLAYED
    }
    expected = {
        name: getattr(UNUSUAL, name)
        for name in NodeConfig.__struct_fields__
        if name not in NOT_REPLAYED
    }
    assert replayed == expected
    assert back.threads == 3


def test_a_journal_without_settings_metadata_replays_with_one_thread() -> None:
    """Tests the default for a recording that has no settings metadata."""
    problem = problem_from({"horizon": 10, "tasks": [make_task()]})
    info = node_info(msgspec.structs.replace(UNUSUAL, threads=4), problem)
    assert config_from_info(info).threads == 1


def test_predictable_replan_settings_reach_the_engine() -> None:
    """Tests that the commit window, stability, move cost and early
    completion gain are the engine's, and that a journal without them
    (an older node) replays with the paper's behaviour."""
    from fsw_scheduler.runtime.policy import engine_config

    engine = engine_config(UNUSUAL)
    assert (
        engine.commit_window,
        engine.stability,
        engine.move_cost,
        engine.early_completion_gain,
        engine.late_completion,
    ) == (6, "lexicographic", 9, 3, "push")
    assert engine.reports_moves
    assert not engine_config(NodeConfig()).reports_moves
    problem = problem_from({"horizon": 10, "tasks": [make_task()]})
    old = config_from_info(node_info(UNUSUAL, problem), {"threads": "1"})
    assert (
        old.commit_window,
        old.stability,
        old.early_completion_gain,
        old.late_completion,
    ) == (0, "off", 0, "off")
