"""Tests of the step columns of the time-indexed model."""

from __future__ import annotations

from fsw_scheduler.analysis.check import check_plan, format_report
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.ilp.model import BuiltModel, solve_ilp

from ..factories import make_doc, make_task, problem_from


def _chain(kind: str, scope: str) -> dict:
    """Three tasks in a chain of precedences of ``kind`` and ``scope``."""
    link = dict(kind=kind, scope=scope)
    return make_doc(
        [
            make_task("a", 2, schedule_cost=3),
            make_task("b", 3, schedule_cost=3),
            make_task("c", 1, schedule_cost=3, delay_cost=2),
        ],
        horizon=12,
        precedences=[
            dict(before="a", after="b", offset=1, **link),
            dict(before="b", after="c", offset=-1, **link),
        ],
    )


def test_tight_chain_of_scope_both_shares_one_task_columns() -> None:
    """Tests that tasks tied by tight precedences of scope both read the
    first task's steps and get no columns or rows of their own."""
    shared = BuiltModel(problem_from(_chain("tight", "both")))
    steps = shared.vars.steps
    assert steps["a"] is steps["b"] is steps["c"]
    # a starts in [0, 6] (b starts 3 later, c 5 later, all end by 12).
    assert shared.num_variables == 7
    assert shared.num_constraints == 6  # the monotone steps alone


def test_shared_columns_keep_the_plan() -> None:
    """Tests that a tight chain of scope both is planned with its offsets
    and its delays counted for every task."""
    problem = problem_from(_chain("tight", "both"))
    plan = solve_ilp(problem, formulation="time-indexed")
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.starts() == {"a": 0, "b": 3, "c": 5}
    assert plan.objective is not None
    assert plan.objective.delay_cost == 0 * 1 + 3 * 1 + 5 * 2
    report = check_plan(problem, plan)
    assert report.ok, format_report(report)


def test_other_precedences_keep_their_own_columns() -> None:
    """Tests that lax or at-least-first precedences share no columns."""
    for kind, scope in (("lax", "both"), ("tight", "at_least_first")):
        steps = BuiltModel(problem_from(_chain(kind, scope))).vars.steps
        assert steps["a"] is not steps["b"]
        assert steps["b"] is not steps["c"]
