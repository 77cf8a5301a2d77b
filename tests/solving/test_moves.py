"""Tests of the move term (stability) in both ILP formulations, the
solve entry point and the checker, against exhaustive search."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.check import check_plan, format_report
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.stability import Stability
from fsw_scheduler.solving.ilp.model import solve_ilp
from fsw_scheduler.solving.solve import solve

from ..factories import bench_lib, make_doc, make_task, problem_from
from ..problems import COMMON, brute_force, decode_doc, problem_docs, show

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem
    from fsw_scheduler.model.stability import Mode

MODES = ("moves", "lexicographic")


def _without_consumables(doc: dict) -> dict:
    """``doc`` without consumables (the disjunctive model has none)."""
    doc["resources"]["consumable"] = {}
    for task in doc["tasks"]:
        task["uses"] = {
            k: v for k, v in task.get("uses", {}).items() if k[0] != "c"
        }
    return doc


@st.composite
def stable_cases(draw: st.DrawFn) -> tuple[dict, Stability]:
    """A small problem and previous starts (in or out of each task's
    window), with a mode and a move cost."""
    doc = _without_consumables(draw(problem_docs(max_tasks=4, max_horizon=8)))
    start, horizon = doc["start"], doc["horizon"]
    previous = {}
    for task in doc["tasks"]:
        if draw(st.integers(0, 3)):
            previous[task["id"]] = draw(
                st.integers(start, start + horizon - 1)
            )
    return doc, Stability(
        previous=previous,
        mode=draw(st.sampled_from(MODES)),
        move_cost=draw(st.integers(1, 9)),
    )


@settings(COMMON, max_examples=60)
@given(case=stable_cases())
def test_both_formulations_find_the_stable_optimum(
    case: tuple[dict, Stability],
) -> None:
    """Tests that with a move term both formulations, ``solve`` and the
    CP-SAT baseline find the exhaustive search's optimum, report its
    moves, and pass the checker, which recomputes the objective with the
    move part."""
    doc, stability = case
    problem = decode_doc(doc)
    best = brute_force(problem, stability)
    cpsat = bench_lib("cpsat").solve_cpsat(
        problem, time_limit=20, stability=stability
    )
    for plan in (
        solve_ilp(problem, formulation="time-indexed", stability=stability),
        solve_ilp(problem, formulation="disjunctive", stability=stability),
        solve(problem, stability=stability),
        cpsat,
    ):
        if best is None:
            assert plan.status is SolveStatus.INFEASIBLE, show(doc, plan)
            continue
        found = f"{show(doc, plan)}\n{stability}\nbrute force: {best}"
        assert plan.status is SolveStatus.OPTIMAL, found
        assert plan.objective is not None
        assert plan.objective.total == best[0].total, found
        assert plan.objective.moves == stability.moves(problem, plan.starts())
        report = check_plan(problem, plan, stability)
        assert report.ok, f"{format_report(report)}\n{found}"


def _three() -> Problem:
    return problem_from(
        make_doc(
            [
                make_task("a", 2, delay_cost=3, uses={"cam": 1}),
                make_task("b", 2, uses={"cam": 1}),
                make_task("c", 3, delay_cost=2),
            ],
            horizon=10,
            resources={"binary": ["cam"]},
        )
    )


@pytest.mark.parametrize("formulation", ["time-indexed", "disjunctive"])
def test_the_three_modes_on_one_problem(formulation: str) -> None:
    """Tests off (pull everything to 0), moves at 2 each (moving all
    three saves 14 units of delay for 6), and lexicographic (nothing
    moves, whatever the delay)."""
    problem = _three()
    previous = {"a": 4, "b": 0, "c": 5}
    modes: tuple[Mode, ...] = ("off", "moves", "lexicographic")
    plans = {
        mode: solve_ilp(
            problem,
            formulation=formulation,
            stability=Stability(previous, mode, 2),
        )
        for mode in modes
    }
    off, moves, lex = plans["off"], plans["moves"], plans["lexicographic"]
    assert off.objective is not None and off.objective.total == 2
    assert b"moves" not in off.to_json().encode()
    assert moves.objective is not None
    assert (moves.objective.moves, moves.objective.move_cost) == (3, 2)
    assert moves.objective.total == 2 + 2 * 3
    assert lex.starts() == previous
    assert lex.objective is not None and lex.objective.moves == 0
    assert lex.objective.delay_cost == 3 * 4 + 2 * 5


def test_checker_names_a_wrong_move_count() -> None:
    """Tests that the checker recomputes moves: a plan claiming none when
    it moved one is an objective violation."""
    problem = _three()
    stability = Stability({"a": 4, "b": 0, "c": 5}, "lexicographic")
    plan = solve_ilp(problem, stability=stability)
    assert check_plan(problem, plan, stability).ok
    assert plan.objective is not None
    lying = plan.replace(
        objective=plan.objective.__class__(0, 22, 22, moves=1)
    )
    report = check_plan(problem, lying, stability)
    assert "objective" in report.rules
