"""Tests of the neighbourhood search (improve.py)."""

from __future__ import annotations

import functools
import time

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.model.plan import Objective
from fsw_scheduler.solving import improve
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.ilp.objective import weight

from ..factories import make_doc, make_task, problem_from
from ..problems import plan_of


def _queue() -> tuple:
    """Three camera tasks of 5 back to back from 0: an optimal plan, which
    no neighbourhood can improve."""
    problem = problem_from(
        make_doc(
            [
                make_task("a", 5, uses={"cam": 1}, delay_cost=3),
                make_task("b", 5, uses={"cam": 1}, delay_cost=2),
                make_task("c", 5, uses={"cam": 1}, delay_cost=1),
            ],
            horizon=40,
            resources={"binary": ["cam"]},
        )
    )
    plan = plan_of(problem, {"a": 0, "b": 5, "c": 10})
    assert check_plan(problem, plan).ok
    return problem, plan, start_domains(problem)


def test_a_stalled_sweep_hands_the_time_over_when_asked_to() -> None:
    """Tests that the search asks ``hand_over`` of its incumbent when a
    sweep finds nothing, once per incumbent, and ends at once when it
    says so, long before its deadline."""
    problem, plan, domains = _queue()
    run = functools.partial(solve_ilp, solver="cbc", threads=1)
    asked = []

    def hand_over(incumbent: object) -> bool:
        asked.append(incumbent)
        return True

    began = time.perf_counter()
    best, improved = improve.improve(
        problem,
        plan,
        domains,
        run,
        began + 60.0,
        hand_over=hand_over,
    )
    assert time.perf_counter() - began < 30.0
    assert improved == 0 and best.starts() == plan.starts()
    assert asked == [plan]


def test_a_stalled_sweep_goes_on_when_not_handed_over() -> None:
    """Tests that a ``hand_over`` saying no lets the search grow its
    neighbourhoods and end by itself, having asked once for the one
    incumbent."""
    problem, plan, domains = _queue()
    run = functools.partial(solve_ilp, solver="cbc", threads=1)
    asked = []

    def hand_over(incumbent: object) -> bool:
        asked.append(incumbent)
        return False

    best, improved = improve.improve(
        problem,
        plan,
        domains,
        run,
        time.perf_counter() + 60.0,
        hand_over=hand_over,
    )
    assert improved == 0 and best.starts() == plan.starts()
    assert asked == [plan]


def test_a_left_out_task_is_freed_with_the_partner_it_needs() -> None:
    """Tests that a neighbourhood freeing a left-out task frees, over its
    whole domain, the left-out partner it cannot run without, even one
    that can only run far from the window: ``a`` (worth 3, at 0-10) and
    ``b`` (worth 3, at 80-95) need each other (a ``both`` precedence)
    and ``x`` (worth 1) holds the camera where ``a`` could run. The
    window about 0 then drops ``x`` for both."""
    problem = problem_from(
        make_doc(
            [
                make_task(
                    "a",
                    5,
                    uses={"cam": 1},
                    schedule_cost=3,
                    feasible_interval=[0, 10],
                ),
                make_task(
                    "b",
                    5,
                    uses={"cam": 1},
                    schedule_cost=3,
                    feasible_interval=[80, 95],
                ),
                make_task(
                    "x",
                    10,
                    uses={"cam": 1},
                    schedule_cost=1,
                    feasible_interval=[0, 10],
                ),
            ],
            horizon=100,
            resources={"binary": ["cam"]},
            precedences=[
                {"before": "a", "after": "b", "kind": "lax", "scope": "both"}
            ],
        )
    )
    plan = plan_of(problem, {"a": None, "b": None, "x": 0})
    domains = start_domains(problem)
    narrowed = improve._neighbourhood(problem, plan, domains, 0, 20, 6)
    assert narrowed is not None
    assert narrowed["b"] == domains["b"]
    run = functools.partial(solve_ilp, solver="cbc", threads=1)
    found = run(problem, domains=narrowed, warm=plan.starts(), time_limit=20)
    assert found.starts() == {"a": 0, "b": 80}
    assert check_plan(problem, found).ok


def test_a_task_in_the_way_may_move_far_from_the_window() -> None:
    """Tests that a neighbourhood's free task may move anywhere in its
    domain: ``m`` (mandatory, at 0) keeps ``w`` (worth 5, only at 0-10)
    out, and ``f`` (pinned: not freed) fills 10-60, so ``m`` has room
    only 50 units past the window; the neighbourhood of ``w`` and ``m``
    over [0, 20) places both."""
    problem = problem_from(
        make_doc(
            [
                make_task("m", 10, uses={"cam": 1}, schedule_cost=0),
                make_task("f", 50, uses={"cam": 1}, schedule_cost=1),
                make_task(
                    "w",
                    10,
                    uses={"cam": 1},
                    schedule_cost=5,
                    feasible_interval=[0, 10],
                ),
            ],
            horizon=100,
            resources={"binary": ["cam"]},
        )
    )
    plan = plan_of(problem, {"m": 0, "f": 10, "w": None})
    assert check_plan(problem, plan).ok
    domains = start_domains(problem)
    narrowed = improve._neighbourhood(problem, plan, domains, 0, 20, 2)
    assert narrowed is not None
    assert narrowed["f"].earliest == narrowed["f"].latest == 10
    run = functools.partial(solve_ilp, solver="cbc", threads=1)
    found = run(problem, domains=narrowed, warm=plan.starts(), time_limit=20)
    assert check_plan(problem, found).ok
    assert found.starts() == {"m": 60, "f": 10, "w": 0}


def test_a_bound_that_settles_the_left_out_cost_frees_placed_tasks() -> None:
    """Tests that once the bound proves no plan leaves out less, a
    neighbourhood spends its free places on the placed tasks whose order
    costs delay, not on left-out ones: ``z`` (worth 1) cannot fit beside
    ``a`` and ``b`` (worth 5 each), the plan runs ``a`` (delay cost 1)
    before ``b`` (delay cost 5). A neighbourhood of 2 over [0, 20) freed
    ``z`` and ``a`` (no gain there); with the bound ``W`` (one unit left
    out at least) it frees ``a`` and ``b``, and CBC swaps them."""
    problem = problem_from(
        make_doc(
            [
                make_task("a", 10, uses={"cam": 1}, delay_cost=1),
                make_task("b", 10, uses={"cam": 1}, delay_cost=5),
                make_task(
                    "z",
                    30,
                    uses={"cam": 1},
                    schedule_cost=1,
                    feasible_interval=[0, 40],
                ),
            ],
            horizon=40,
            resources={"binary": ["cam"]},
        )
    )
    plan = plan_of(problem, {"a": 0, "b": 10, "z": None})
    assert check_plan(problem, plan).ok
    assert plan.objective is not None
    domains = start_domains(problem)
    big = weight(problem)
    assert not improve.settled(plan, None)
    assert not improve.settled(plan, big - 1)
    assert improve.settled(plan, big)
    # A move term: the moves' price is part of what a bound may miss.
    priced = plan.replace(
        objective=Objective(1, 10, big + 2 * 5 + 10, moves=2, move_cost=5)
    )
    assert improve.settled(priced, big)
    assert not improve.settled(priced, big - 1)
    # Lexicographic moves: their weight is not on the objective.
    lexicographic = plan.replace(
        objective=Objective(1, 10, big + 7 * big + 10, moves=1)
    )
    assert not improve.settled(lexicographic, big + 7 * big)
    unsettled = improve._neighbourhood(problem, plan, domains, 0, 20, 2)
    assert unsettled is not None
    assert not unsettled["z"].empty
    assert unsettled["b"] == type(unsettled["b"])(10, 10)
    narrowed = improve._neighbourhood(problem, plan, domains, 0, 20, 2, True)
    assert narrowed is not None
    assert narrowed["z"].empty
    assert narrowed["a"] == domains["a"] and narrowed["b"] == domains["b"]
    run = functools.partial(solve_ilp, solver="cbc", threads=1)
    found = run(problem, domains=narrowed, warm=plan.starts(), time_limit=20)
    assert check_plan(problem, found).ok
    assert found.starts() == {"a": 10, "b": 0}
    assert found.objective is not None
    assert found.objective.total < plan.objective.total
