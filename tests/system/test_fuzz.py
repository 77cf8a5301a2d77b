"""Tests of ``tools/fuzz``: odd shapes and their replans judged against
CP-SAT."""

from __future__ import annotations

import json
import logging
import subprocess
import sys

import pytest

from fsw_scheduler.model.change import Removal, decode_change
from fsw_scheduler.model.plan import Activity, Objective, Plan, SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.replan.diff import PlanDiff
from fsw_scheduler.solving.ilp.cbc import CbcRun
from fsw_scheduler.solving.ilp.program import EQ, Program

from ..factories import (
    ROOT,
    bench_lib,
    make_doc,
    make_task,
    problem_from,
    tool_script,
)

odd = bench_lib("odd")
pytest.importorskip("ortools.sat.python.cp_model")


def test_replan_changes_are_valid_documents_of_every_kind() -> None:
    """Over a few seeds the draw gives goals, failures and levels, each a
    document the change decoder takes, at a unit inside the plan."""
    kinds = set()
    for seed in range(60):
        doc = odd.generate_problem(seed)
        activities = [
            {
                "task": task["id"],
                "start": doc["start"],
                "end": doc["start"] + task["length"],
            }
            for task in doc["tasks"][:3]
        ]
        now, change = odd.replan_change(doc, {"activities": activities}, seed)
        assert doc["start"] <= now <= doc["start"] + doc["horizon"]
        decode_change(json.dumps(change).encode())
        kinds.add(change.get("event", "goal"))
        if "tasks" in change:
            ids = {task["id"] for task in doc["tasks"]}
            assert not ids & {task["id"] for task in change["tasks"]}
    assert kinds == {"goal", "activity_failed", "levels"}


def test_what_the_checker_cannot_see_in_a_replan_is_a_finding() -> None:
    """An activity placed before the replan's unit, a task with no
    verdict and a task taken as finished before its end are named."""
    fuzz = tool_script("fuzz", "fuzz_tool")
    old = decode_problem(
        json.dumps(
            {
                "horizon": 40,
                "resources": {},
                "tasks": [
                    {
                        "id": name,
                        "length": 2,
                        "delay_cost": 1,
                        "schedule_cost": 1,
                    }
                    for name in ("a", "b", "c")
                ],
            }
        ).encode()
    )
    new = decode_problem(
        json.dumps(
            {
                "horizon": 40,
                "resources": {},
                "tasks": [
                    {
                        "id": "b",
                        "length": 2,
                        "delay_cost": 1,
                        "schedule_cost": 1,
                    }
                ],
            }
        ).encode()
    )
    before = Plan(
        SolveStatus.OPTIMAL,
        None,
        (Activity("a", 0, 2), Activity("b", 10, 12), Activity("c", 3, 5)),
        (),
    )
    fine = Plan(SolveStatus.OPTIMAL, None, (Activity("b", 14, 16),), ())
    done = (
        Removal("a", "finished"),
        Removal("c", "finished"),
    )
    assert fuzz.replan_findings(old, before, new, fine, _diff(done), 8) == []
    wrong = Plan(SolveStatus.OPTIMAL, None, (Activity("b", 7, 9),), ())
    assert fuzz.replan_findings(
        old, before, new, wrong, _diff(done[:1]), 8
    ) == [
        "rewrites the past: b at 7 < 8",
        "lost: c has no verdict",
    ]
    assert fuzz.replan_findings(old, before, new, fine, _diff(done), 4) == [
        "finished early: c ends at 5 > 4"
    ]


def test_a_pin_the_plan_does_not_keep_is_a_finding_unless_named() -> None:
    """Tests the commit window's check: a pinned start kept is fine; one
    moved is a finding, unless the plan is ``degraded`` and its ``why``
    names the pin (cause ``commit_window``)."""
    from fsw_scheduler.model.plan import Blocker

    fuzz = tool_script("fuzz", "fuzz_tool")
    pins = {"a": 4, "b": 9}
    kept = Plan(
        SolveStatus.OPTIMAL,
        None,
        (Activity("a", 4, 6), Activity("b", 9, 11)),
        (),
    )
    assert fuzz.pin_findings(pins, kept) == []
    moved = Plan(
        SolveStatus.OPTIMAL,
        None,
        (Activity("a", 4, 6), Activity("b", 12, 14)),
        (),
    )
    assert fuzz.pin_findings(pins, moved) == [
        "breaks the pin of b at 9 (not degraded)"
    ]
    named = Plan(
        SolveStatus.DEGRADED,
        None,
        (Activity("a", 4, 6),),
        ("b",),
        why=(Blocker("b", "commit_window", "left out"),),
    )
    assert fuzz.pin_findings(pins, named) == []
    unnamed = named.replace(why=())
    assert fuzz.pin_findings(pins, unnamed) == ["breaks the pin of b at 9"]


def test_no_plan_where_cp_sat_has_one_is_weak() -> None:
    """Tests that an ``unknown`` answer (no plan) where CP-SAT found a
    plan, proved or not, is a ``weak`` finding: a day with a plan left
    without one (``tools/fuzz --large`` seeds 1182 and 1192: 47-53 task
    parts that list scheduling could not start)."""
    fuzz = tool_script("fuzz", "fuzz_tool")
    problem = problem_from(make_doc([make_task("a")], horizon=10))
    none = Plan(SolveStatus.UNKNOWN, None)
    found = Plan(
        SolveStatus.FEASIBLE,
        Objective(0, 0, 0),
        (Activity("a", 0, 2),),
    )
    assert fuzz.findings(problem, none, 1.0, 20.0, found) == [
        "weak: no plan at 20 s, CP-SAT has one"
    ]
    assert fuzz.findings(problem, none, 1.0, 20.0, none) == []


def _diff(removed: tuple[Removal, ...]) -> PlanDiff:
    return PlanDiff(kept=(), continued=(), moved=(), added=(), removed=removed)


def test_fuzz_replans_judges_each_replan_against_cp_sat() -> None:
    """The tool as a user runs it: every replan judged, none wrong."""
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "fuzz"),
            "--replans",
            "--first",
            "1",
            "--count",
            "30",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    lines = result.stdout.splitlines()
    assert lines[-1] == "0 problems with a wrong or late answer"
    judged = [line for line in lines if "| cpsat" in line]
    assert len(judged) >= 15
    for kind in ("goal", "activity_failed", "levels", "commit window"):
        assert any(kind in line for line in judged), kind


def test_a_warm_start_cbc_did_not_take_is_counted() -> None:
    """Tests that the fuzz tool counts the solver's warnings that CBC did
    not take a warm start as given, and no other warning, on real CBC
    runs: a start that breaks the program's one row (one of three
    binaries set where two must be) and one that keeps it."""
    fuzz = tool_script("fuzz", "fuzz_tool")
    refused = fuzz.RefusedStarts()
    logger = logging.getLogger("fsw_scheduler.solver")
    logger.addHandler(refused)
    try:
        logger.warning("cbc exited with -11; retrying with preprocessing")
        assert refused.count == 0
        program = Program()
        cols = [program.add_column(0, 1, integer=True) for _ in range(3)]
        program.add_row(dict.fromkeys(cols, 1), EQ, 2)
        program.set_objective({c: k + 1 for k, c in enumerate(cols)})
        result = CbcRun(time_limit=10).solve(program, [0.0, 0.0, 1.0])
        assert result.status is SolveStatus.OPTIMAL
        assert refused.count == 1
        CbcRun(time_limit=10).solve(program, [1.0, 1.0, 0.0])
        assert refused.count == 1
    finally:
        logger.removeHandler(refused)
