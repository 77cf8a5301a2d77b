"""Tests of polishing a plan: kept tasks moved earlier where that pays."""

from __future__ import annotations

import functools
import itertools
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.analysis import polish
from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import checked_starts, greedy_plan
from fsw_scheduler.analysis.polish import polished
from fsw_scheduler.model.plan import Activity, SolverStats, SolveStatus
from fsw_scheduler.solving import solve as solving
from fsw_scheduler.solving.ilp import solve_ilp

from ..factories import bench_lib, large_suite_problem, make_task, problem_from
from ..problems import plan_of

RUN = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)

if TYPE_CHECKING:
    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.model.problem import Problem


def _camera(a_cost: int = 5, b_cost: int = 1, **extra: object) -> Problem:
    """One camera over 12 units: ``a`` (2 units, delay cost ``a_cost``)
    and ``b`` (4 units, delay cost ``b_cost``)."""
    return problem_from(
        {
            "horizon": 12,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task("a", 2, delay_cost=a_cost, uses={"camera": 1}),
                make_task("b", 4, delay_cost=b_cost, uses={"camera": 1}),
            ],
            **extra,
        }
    )


def _total(plan: Plan) -> int:
    assert plan.objective is not None
    return plan.objective.total


def test_a_task_with_room_before_it_moves_there() -> None:
    """Tests the shift: ``a`` after a gap starts where ``b`` ends, and
    the plan keeps its status and left-out tasks (``b`` the dearer, so
    no push before it pays)."""
    problem = _camera(a_cost=1, b_cost=5)
    plan = plan_of(problem, {"b": 0, "a": 7}).replace(
        status=SolveStatus.FEASIBLE
    )
    better = polished(problem, plan, start_domains(problem))
    assert better.activities == (Activity("b", 0, 4), Activity("a", 4, 6))
    assert better.status is SolveStatus.FEASIBLE
    assert check_plan(problem, better).ok
    assert _total(better) == _total(plan) - 3


def test_a_cheap_task_in_the_way_starts_after_a_dear_one() -> None:
    """Tests the push: ``a`` (5 a unit) goes to 0 and ``b`` (1 a unit),
    in its way, starts at ``a``'s end: 20 saved, 2 lost."""
    problem = _camera()
    plan = plan_of(problem, {"b": 0, "a": 4})
    better = polished(problem, plan, start_domains(problem))
    assert better.activities == (Activity("a", 0, 2), Activity("b", 2, 6))
    assert check_plan(problem, better).ok
    assert _total(better) == _total(plan) - 20 + 2


def test_a_push_that_costs_more_than_it_saves_is_not_made() -> None:
    """Tests that with ``b`` the dearer (a 1 a unit, ``b`` 5: 4 saved, 10
    lost) the plan itself comes back."""
    problem = _camera(a_cost=1, b_cost=5)
    plan = plan_of(problem, {"b": 0, "a": 4})
    assert polished(problem, plan, start_domains(problem)) is plan


def test_a_precedence_holds_a_task_where_it_is() -> None:
    """Tests that ``a`` which must follow ``b`` with 3 units between
    stays at ``b``'s end + 3, as the checker requires."""
    problem = _camera(
        precedences=[{"before": "b", "after": "a", "kind": "lax", "offset": 3}]
    )
    plan = plan_of(problem, {"b": 0, "a": 7})
    assert polished(problem, plan, start_domains(problem)) is plan


def test_a_stop_and_the_budget_bound_the_work() -> None:
    """Tests that a caller's stop or no checks left return the plan
    itself, and that at most ``max_checks`` plans are checked."""
    problem = _camera()
    plan = plan_of(problem, {"b": 0, "a": 7})
    domains = start_domains(problem)
    assert polished(problem, plan, domains, stop=lambda: True) is plan
    assert polished(problem, plan, domains, max_checks=0) is plan
    asked = []

    def stop() -> bool:
        asked.append(1)
        return False

    polished(problem, plan, domains, stop=stop, max_checks=1)
    assert len(asked) == 1


def test_a_plan_without_objective_comes_back_as_it_is() -> None:
    """Tests that a plan the caller has not scored is not touched."""
    problem = _camera()
    plan = plan_of(problem, {"b": 0, "a": 7}).replace(objective=None)
    assert polished(problem, plan, start_domains(problem)) is plan


def _check(problem: Problem, plan: Plan) -> Plan:
    """Polish ``plan`` and assert what every polish must keep."""
    domains = start_domains(problem)
    better = polished(problem, plan, domains)
    report = check_plan(problem, better)
    assert report.ok, report.violations
    assert report.objective == better.objective
    assert _total(better) <= _total(plan)
    # The same tasks kept, the same options chosen; moves only earlier
    # for the task that gained, so never a task out of its domain.
    assert {a.task for a in better.activities} == {
        a.task for a in plan.activities
    }
    assert better.unscheduled == plan.unscheduled
    assert better.chosen == plan.chosen
    # No clock in the decisions.
    assert polished(problem, plan, domains) == better
    return better


@pytest.mark.parametrize("style", ["broad", "paper"])
def test_generated_start_plans_stay_valid_and_only_improve(
    style: str,
) -> None:
    """Tests on every 10- and 15-task campaign problem of one seed (all
    resource kinds, precedences, windows) that the polished start plan
    passes the checker, keeps its tasks and costs no more."""
    generator = bench_lib("generator")
    problems = [
        b.problem()
        for b in generator.suite("campaign", 71, style)
        if b.num_tasks >= 10
    ]
    gained = 0
    for problem in problems:
        start = greedy_plan(problem, domains=start_domains(problem))
        if start is None or start.objective is None:
            continue
        gained += _total(start) - _total(_check(problem, start))
    assert gained > 0


def test_mission_model_plans_keep_their_options() -> None:
    """Tests on the mission suite (alternatives, resources that change
    with the orbit) that a polished plan keeps its chosen options and
    passes the checker."""
    generator = bench_lib("generator")
    for bench in itertools.islice(generator.mission_suite(71), 0, None, 3):
        problem = bench.problem()
        start = greedy_plan(problem, domains=start_domains(problem))
        if start is not None and start.objective is not None:
            _check(problem, start)


def test_a_large_broad_plan_is_polished_within_its_checks() -> None:
    """Tests a 60-task broad problem over H = 1440 (binary and multiple
    resources, a battery): valid, no worse, within MAX_CHECKS."""
    problem = large_suite_problem(59, "b60-h1440")
    start = greedy_plan(problem, domains=start_domains(problem))
    assert start is not None
    asked = []

    def stop() -> bool:
        asked.append(1)
        return False

    better = polished(problem, start, start_domains(problem), stop=stop)
    assert check_plan(problem, better).ok
    assert _total(better) <= _total(start)
    assert len(asked) <= (
        polish.MAX_CHECKS + polish.MAX_REFUSED // polish.ASK_EVERY
    )


def test_an_unproved_answer_is_polished_and_says_so() -> None:
    """Tests the solve's last step on a plan CBC left unproved: moved
    earlier, still ``feasible``, its status line saying what it saved;
    a proved answer is left as it is."""
    problem = _camera(a_cost=1, b_cost=5)
    stats = SolverStats(solver="cbc", solver_status="Stopped on time")
    plan = plan_of(problem, {"b": 0, "a": 7}).replace(
        status=SolveStatus.FEASIBLE, stats=stats
    )
    domains = start_domains(problem)
    far = 1e12  # no deadline in the way
    better = solving._polishing(problem, plan, domains, far, RUN)
    assert better.status is SolveStatus.FEASIBLE
    assert better.activities == (Activity("b", 0, 4), Activity("a", 4, 6))
    assert better.stats is not None
    assert better.stats.solver_status == (
        "Stopped on time; tasks moved earlier: 3 delay units saved"
    )
    proved = plan.replace(status=SolveStatus.OPTIMAL)
    assert solving._polishing(problem, proved, domains, far, RUN) is proved
    # Past the deadline: nothing is tried.
    assert solving._polishing(problem, plan, domains, 0.0, RUN) is plan


def _moves(
    problem: Problem, plan: Plan
) -> list[tuple[dict[str, int], list[str]]]:
    """Plans one or two kept tasks away from ``plan``: each kept task at
    every few starts of its domain, and with the next kept task at its
    new end."""
    domains = start_domains(problem)
    starts = plan.starts()
    names = sorted(starts)
    lengths = {t.id: t.length for t in problem.tasks}
    found = []
    for k, name in enumerate(names):
        domain = domains[name]
        step = max(1, (domain.latest - domain.earliest) // 12)
        for at in range(domain.earliest, domain.latest + 1, step):
            moved = dict(starts)
            moved[name] = at
            found.append((moved, [name]))
            other = names[(k + 1) % len(names)]
            if other != name:
                pushed = dict(moved)
                pushed[other] = at + lengths[name]
                found.append((pushed, [name, other]))
    return found


@pytest.mark.parametrize("suite", ["campaign", "mission", "large"])
def test_a_move_refused_before_a_check_is_one_the_checker_refuses(
    suite: str,
) -> None:
    """Tests the polish's refusal before a check against the checker on
    moves of one and two tasks of generated start plans (every resource
    kind, precedences tight and lax, windows, capacity steps and binary
    windows in the mission suite): every move it refuses the checker
    refuses too, and it refuses most of the moves the checker refuses
    (it is what makes the polish cheap)."""
    generator = bench_lib("generator")
    if suite == "campaign":
        benches = [
            b
            for b in generator.suite("campaign", 72, "broad")
            if b.num_tasks >= 10
        ]
    elif suite == "mission":
        benches = list(
            itertools.islice(generator.mission_suite(72), 0, None, 4)
        )
    else:
        benches = [
            b
            for b in generator.large_suite(72)
            if b.name in ("b30-h1440", "f30-h1440")
        ]
    refused = refusable = 0
    for bench in benches:
        problem = bench.problem()
        domains = start_domains(problem)
        start = greedy_plan(problem, domains=domains)
        if start is None or start.objective is None or not start.activities:
            continue
        judge = polish._Polish(problem, start, domains, None, 0)
        for starts, moved in _moves(problem, start):
            says = judge._refused(starts, moved)
            valid = checked_starts(problem, starts) is not None
            assert not (says and valid), (bench.name, moved, starts)
            refused += says
            refusable += not valid
    assert refusable > 0
    assert refused >= refusable // 2
