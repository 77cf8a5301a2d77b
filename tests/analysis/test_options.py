"""Tests of the proof that a mandatory group has no option that fits
(fsw_scheduler.analysis.options)."""

from __future__ import annotations

from hypothesis import given, settings

from fsw_scheduler.analysis.options import impossible_group
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.solve import solve

from ..factories import make_doc, make_task, problem_from
from ..problems import COMMON, brute_force, decode_doc, mission_docs


def _pass_doc(second_window: list[int]) -> dict:
    """A downlink pinned at 10 on the antenna, and a mandatory group of
    two passes on it: the first inside the downlink's time, the second in
    ``second_window``."""
    down = make_task("down", 6, schedule_cost=0, uses={"ant": 1})
    down["fixed_start"] = 10
    first = make_task("p0", 4, uses={"ant": 1}, feasible_interval=[11, 16])
    second = make_task("p1", 4, uses={"ant": 1})
    second["feasible_interval"] = second_window
    for task in (first, second):
        task["feasible_interval_applies_to"] = "task"
        del task["schedule_cost"]
    doc = make_doc(
        [down, first, second, make_task("free", 2)],
        horizon=60,
        resources={"binary": ["ant"]},
    )
    doc["alternatives"] = [
        {"id": "pass", "schedule_cost": 0, "options": [["p0"], ["p1"]]}
    ]
    return doc


def test_a_mandatory_group_none_of_whose_options_fits() -> None:
    """Tests that a mandatory group whose every option is kept out by a
    pinned task is proved infeasible without a solve, each option's proof
    named; and that one option with room gives a plan instead."""
    problem = problem_from(_pass_doc([8, 15]))
    proof = impossible_group(problem)
    assert {(b.task, b.cause) for b in proof} == {
        ("p0", "combination"),
        ("p1", "combination"),
    }, proof
    detail = proof[0].detail
    assert "one option of group pass must be scheduled and none fits" in (
        detail
    ), detail
    assert "option 0 (p0)" in detail and "option 1 (p1)" in detail, detail
    plan = solve(problem, time_limit=10)
    assert plan.status is SolveStatus.INFEASIBLE
    assert plan.stats is not None and plan.stats.solver == "proof"
    roomy = problem_from(_pass_doc([16, 30]))
    assert not impossible_group(roomy)
    plan = solve(roomy, time_limit=10)
    assert plan.status is SolveStatus.OPTIMAL
    assert {a.task for a in plan.activities} >= {"down", "p1"}


def test_no_proof_once_time_is_up() -> None:
    """Tests that the options are not tried once ``stop`` says time is
    up."""
    problem = problem_from(_pass_doc([8, 15]))
    assert not impossible_group(problem, stop=lambda: True)


@settings(COMMON, max_examples=200)
@given(doc=mission_docs(max_tasks=4, max_horizon=8))
def test_a_group_proof_is_never_given_for_a_feasible_problem(
    doc: dict,
) -> None:
    """Tests that on problems with every field of the mission model the
    group proof is only given where exhaustive search finds no plan."""
    for group in doc.get("alternatives", []):
        group["schedule_cost"] = 0  # the proof's case, as often as can be
    problem = decode_doc(doc)
    if impossible_group(problem):
        assert brute_force(problem) is None, doc
