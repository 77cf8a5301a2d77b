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


def test_the_table_says_whether_the_replan_target_is_met() -> None:
    """Tests the last line of the replan table: the target (median under
    2 s, every plan no worse than the fresh solve's) met or not, with the
    median and the cases whose plan is worse named."""

    def case(name: str, seconds: float, total: int, fresh: int) -> object:
        return replans.ReplanCase(
            name, 30, seconds, 9.5, "feasible", "feasible", total, fresh,
            None, "cbc", True,
        )  # fmt: skip

    fast = [case("a", 0.5, 10, 10), case("b", 1.0, 10, 12)]
    line = replans.format_cases(fast).splitlines()[-1]
    assert line == (
        "target, median under 2 s and every plan no worse than the fresh "
        "solve's: met (median 0.75 s; worse: none)"
    )
    slow = [*fast, case("c", 9.0, 11, 10), case("d", 9.0, 10, 10)]
    line = replans.format_cases(slow).splitlines()[-1]
    assert "NOT met (median 5.00 s; worse: c)" in line
