"""Tests of the consumable rows of the time-indexed model."""

from __future__ import annotations

from hypothesis import assume, given, settings

from fsw_scheduler.analysis.check import check_plan, format_report
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.ilp.model import BuiltModel, solve_ilp

from ..factories import make_doc, make_task, problem_from
from ..problems import (
    COMMON,
    assert_brute_force_optimum,
    decode_doc,
    problem_docs,
    show,
)


def _level_columns(doc: dict) -> int:
    """Number of continuous (level) columns in the time-indexed model."""
    program = BuiltModel(problem_from(doc)).program
    return program.integer.count(False)


def _uses_consumable(doc: dict) -> bool:
    consumables = doc["resources"]["consumable"]
    return any(
        amount and name in consumables
        for task in doc["tasks"]
        for name, amount in task.get("uses", {}).items()
    )


def _assert_exact(doc: dict) -> None:
    problem = decode_doc(doc)
    plan = solve_ilp(problem, formulation="time-indexed")
    objective = assert_brute_force_optimum(doc, problem, plan)
    if objective is None:
        return
    # Not only the total: the unscheduled and delay parts too.
    assert plan.objective == objective, show(doc, plan)
    report = check_plan(problem, plan)
    assert report.ok, f"{format_report(report)}\n{show(doc, plan)}"


@settings(COMMON, max_examples=150)
@given(doc=problem_docs(max_tasks=4, max_horizon=10))
def test_time_indexed_optimum_matches_brute_force(doc: dict) -> None:
    """Tests that the time-indexed model's optimum with consumables in use
    equals exhaustive search."""
    assume(_uses_consumable(doc))
    _assert_exact(doc)


@settings(COMMON, max_examples=100)
@given(doc=problem_docs(max_tasks=4, max_horizon=10, capacities=True))
def test_time_indexed_optimum_matches_brute_force_with_capacity(
    doc: dict,
) -> None:
    """Tests that the time-indexed model's optimum with capped consumables
    equals exhaustive search."""
    assume(_uses_consumable(doc))
    _assert_exact(doc)


def _store_doc(*tasks: dict, initial: float = 4) -> dict:
    return make_doc(
        list(tasks), horizon=20, resources={"consumable": {"c": initial}}
    )


def test_no_level_columns_without_generation() -> None:
    """Tests that a consumable nothing generates gets no level columns
    (its knapsack row is exact)."""
    doc = _store_doc(
        make_task("a", 3, uses={"c": 1}),
        make_task("b", 3, uses={"c": 1}),
    )
    assert _level_columns(doc) == 0


def test_level_columns_only_next_to_generation() -> None:
    """Tests that levels are kept only at the units next to those in which
    a generator can run, and at the last unit."""
    doc = _store_doc(
        make_task("a", 3, uses={"c": 1}),
        make_task("b", 3, uses={"c": 1}),
        # Runs in [10, 12] at the latest, so units 9 to 12 and 19.
        make_task(
            "g",
            2,
            uses={"c": -1},
            feasible_interval=[10, 13],
            feasible_interval_applies_to="task",
        ),
    )
    assert _level_columns(doc) == 5


def test_level_falls_below_zero_before_late_generation() -> None:
    """Tests that two consumers that fit the store alone but not together
    before the only generation are not both scheduled, though the store
    suffices over the horizon."""
    early = dict(feasible_interval=[0, 6], feasible_interval_applies_to="task")
    doc = _store_doc(
        make_task("a", 2, uses={"c": 1}, schedule_cost=5, **early),
        make_task("b", 2, uses={"c": 1}, schedule_cost=5, **early),
        make_task("g", 3, uses={"c": -4}, feasible_interval=[8, 14]),
        initial=2,
    )
    problem = problem_from(doc)
    plan = solve_ilp(problem, formulation="time-indexed")
    assert plan.status is SolveStatus.OPTIMAL
    assert len({"a", "b"} & set(plan.unscheduled)) == 1, show(doc, plan)
    report = check_plan(problem, plan)
    assert report.ok, format_report(report)
