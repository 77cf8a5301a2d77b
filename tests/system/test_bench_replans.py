"""Tests of the replan benchmark (tools/bench_lib/replans.py)."""

from __future__ import annotations

import subprocess
import sys

from fsw_scheduler.model.change import decode_change
from fsw_scheduler.model.goal import Goal

from ..factories import ROOT, bench_lib

replans = bench_lib("replans")
generator = bench_lib("generator")


def test_goal_is_a_valid_two_task_goal() -> None:
    """Tests that the benchmark's goal decodes, uses the fresh shape's
    resources and is the same for the same seed."""
    doc = replans.goal_doc(7)
    goal = decode_change(generator.dump_json(doc))
    assert isinstance(goal, Goal)
    assert len(goal.tasks) == 2
    assert replans.goal_doc(7) == doc != replans.goal_doc(8)


def test_one_case_replans_and_solves_afresh() -> None:
    """Tests that a case solves, replans from the plan in force and solves
    afresh, with valid plans, and that the table shows it and a median."""
    lines: list[str] = []
    cases = replans.run_cases(
        3, time_limit=3, per_size=1, progress=lines.append, sizes=(30,)
    )
    assert len(cases) == 1 and lines
    case = cases[0]
    assert case.valid
    assert case.replan_total is not None and case.fresh_total is not None
    assert case.no_worse == (case.replan_total <= case.fresh_total)
    text = replans.format_cases(cases)
    assert case.name in text and "median" in text


def test_bench_replan_suite_help() -> None:
    """Tests that tools/bench offers the replan suite."""
    out = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "bench"), "--help"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert "replan" in out
