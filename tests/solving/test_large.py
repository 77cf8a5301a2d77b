"""Tests of the large parts' routing and search (large.py)."""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from pathlib import Path
from typing import TYPE_CHECKING

from fsw_scheduler.analysis.bounds import kept_set_bound, kept_set_starts
from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_count, start_domains
from fsw_scheduler.analysis.greedy import greedy_plan
from fsw_scheduler.api import replan_typed
from fsw_scheduler.model.change import decode_change
from fsw_scheduler.model.plan import SolverStats, SolveStatus, objective_weight
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving import large, replanning
from fsw_scheduler.solving.budget import BUDGET
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.incumbent import finished
from fsw_scheduler.solving.rounds import LONG_COLUMNS
from fsw_scheduler.solving.solve import solve

from ..factories import (
    bench_lib,
    large_suite_problem,
    make_doc,
    make_task,
    problem_from,
)
from ..problems import plan_of

if TYPE_CHECKING:
    import pytest

    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.model.problem import Problem


def test_the_search_takes_parts_from_lns_min_tasks() -> None:
    """Tests that a part goes to the neighbourhood search from
    BUDGET.lns_min_tasks tasks on, however long its horizon, and that a
    29-task part over H = 2880 (a model of more than 15,000 columns)
    still goes whole to CBC."""
    fresh = bench_lib("fresh")
    thirty = problem_from(fresh.generate_problem(30, 336, 3))
    assert thirty.num_tasks == BUDGET.lns_min_tasks
    assert large.searched(thirty)
    long = problem_from(fresh.generate_problem(29, 2880, 3))
    assert start_count(start_domains(long)) > 15_000
    assert not large.searched(long)


def test_a_large_part_with_a_small_model_is_proved_before_any_search() -> None:
    """Tests that a 30-task part whose relaxation or whole model, narrowed
    around its start plan, is small is proved before any search
    (b30-h1440 of the large suite, seed 31: proved in about 3 s by the
    whole model, now by the disjunctive relaxation; the search first
    took 11 s)."""
    generator = bench_lib("generator")
    bench = next(b for b in generator.large_suite(31) if b.name == "b30-h1440")
    problem = bench.problem()
    assert large.searched(problem)
    plan = solve(problem, time_limit=20)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "neighbourhood search" not in plan.stats.solver_status
    assert plan.stats.gap == 0.0
    assert check_plan(problem, plan).ok


def test_a_replan_whose_bound_runs_out_of_nodes_searches_it_again(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that a replan whose kept-set search runs out of its own few
    nodes searches again with a fresh solve's, so its plan still carries
    a bound that holds."""
    fresh = bench_lib("fresh")
    problem = problem_from(fresh.generate_problem(30, 336, 2))
    domains = start_domains(problem)
    in_force = greedy_plan(problem, domains=domains)
    assert in_force is not None
    monkeypatch.setattr(replanning, "REPLAN_BOUND_NODES", 1)
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    plan = replanning.replanned(
        problem, in_force, domains, run, time.perf_counter(), 3.0
    )
    assert plan is not None and check_plan(problem, plan).ok
    assert plan.objective is not None
    assert plan.stats is not None and plan.stats.bound is not None
    assert plan.stats.bound <= plan.objective.total + 0.5


def test_a_replan_the_repair_cannot_start_keeps_what_holds(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that a replan whose plan in force overdraws the battery on the
    new problem (the repair gives up) is solved afresh from what of the
    plan in force still holds when that beats the start heuristic's plan
    (stopped at once here, as under load: the tasks every plan must hold
    alone, none)."""
    doc = make_doc(
        [make_task(name, 4, uses={"battery": 1}) for name in "abc"],
        horizon=20,
        resources={"consumable": {"battery": 8}},
    )
    problem = problem_from(doc)
    domains = start_domains(problem)
    in_force = plan_of(problem, {"a": 0, "b": 4, "c": 8})
    assert not check_plan(problem, in_force).ok
    for module in (large, replanning):
        monkeypatch.setattr(
            module, "BUDGET", dataclasses.replace(BUDGET, greedy_share=0.0)
        )
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    plan = replanning.replanned(
        problem, in_force, domains, run, time.perf_counter(), 0.3
    )
    assert plan is not None and check_plan(problem, plan).ok
    assert plan.objective is not None
    # Two of the three kept: one left out, as the best plan.
    assert plan.objective.unscheduled_cost == 1, plan


def _replan_suite_case(
    seed: int, name: str, limit: float
) -> tuple[Problem, Plan, float]:
    """The replan suite's case ``name`` of ``seed`` (``r45-...``): its day
    solved with ``limit``, then its goal replanned with ``limit``; the
    new problem, the replan's plan and its wall time."""
    replans = bench_lib("replans")
    generator = bench_lib("generator")
    own = generator.problem_seed(seed, name)
    problem = problem_from(
        bench_lib("fresh").generate_problem(
            int(name[1:3]), replans.HORIZON, own
        )
    )
    first = solve(problem, time_limit=limit)
    assert first.status.has_plan
    goal = decode_change(generator.dump_json(replans.goal_doc(own)))
    began = time.perf_counter()
    new_problem, plan, _ = replan_typed(
        problem, first, goal, replans.GOAL_AT, time_limit=limit
    )
    return new_problem, plan, time.perf_counter() - began


def test_a_replan_the_relaxation_proves_is_proved_within_its_share() -> None:
    """Tests that a goal on a 45-task plan whose new part the disjunctive
    relaxation proves is answered optimal from the replan's own share of
    the limit (replan suite, seed 20's r45-h1440-1: the search around
    the change alone ended 140 units above the optimum)."""
    # A replan's share of 30 s (6 s) is more than the relaxation needs
    # on an idle core (0.3 s): the suite's other worker shares the core.
    limit = 30.0
    new_problem, plan, wall = _replan_suite_case(20, "r45-h1440-1", limit)
    assert check_plan(new_problem, plan).ok
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None and plan.stats.solver == "cbc-relaxed"
    assert wall < BUDGET.replan_limit(limit) + 0.5, plan.stats


def test_a_replan_solved_afresh_runs_the_relaxation_from_its_share() -> None:
    """Tests that a replan the repair cannot start (its plan in force, all
    at the earliest starts, breaks the resources) still runs the
    disjunctive relaxation within a replan's limit, under a fresh solve's
    5 s minimum, and is proved by it (replan suite, seed 23's
    r45-h1440-1 ended 627,089 above the fresh solve's optimum without)."""
    replans = bench_lib("replans")
    own = bench_lib("generator").problem_seed(20, "r45-h1440-1")
    problem = problem_from(
        bench_lib("fresh").generate_problem(45, replans.HORIZON, own)
    )
    domains = start_domains(problem)
    broken = plan_of(
        problem, {t.id: domains[t.id].earliest for t in problem.tasks}
    )
    assert not check_plan(problem, broken).ok
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    # 4 s: twice a replan's usual share, for the suite's other worker;
    # still under the 5 s a fresh solve needs to try the relaxation.
    plan = replanning.replanned(
        problem, broken, domains, run, time.perf_counter(), 4.0
    )
    assert plan is not None and check_plan(problem, plan).ok
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None and plan.stats.solver == "cbc-relaxed"


def _first_place_taken() -> tuple[Problem, Plan]:
    """A 30-task part on one camera, and a plan of it that leaves ``b``
    (worth 5, which can only run first) out, ``a00`` in its place."""
    tasks = [
        make_task("b", 10, schedule_cost=5, uses={"camera": 1}),
        *(make_task(f"a{k:02d}", 10, uses={"camera": 1}) for k in range(29)),
    ]
    tasks[0]["feasible_interval"] = [0, 10]
    problem = problem_from(
        make_doc(tasks, horizon=600, resources={"binary": ["camera"]})
    )
    assert large.searched(problem)
    plan = plan_of(
        problem, {"b": None} | {f"a{k:02d}": 10 * k for k in range(29)}
    )
    return problem, plan


def test_a_left_out_task_is_inserted_before_the_search() -> None:
    """Tests that a large part's start plan gets a left-out task back by
    moving the one in its way before any search, and says so: ``b``
    (worth 5) can only run first, where the start plan put ``a00``."""
    problem, start = _first_place_taken()
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    plan = large.improved(
        problem,
        start,
        start_domains(problem),
        run,
        time.perf_counter(),
        1.0,
    )
    assert plan.stats is not None
    assert plan.stats.solver_status.startswith(
        "1 left-out tasks inserted into the start plan"
    )
    assert plan.unscheduled == ()
    assert plan.starts()["b"] == 0
    assert check_plan(problem, plan).ok
    assert plan.objective is not None and start.objective is not None
    assert plan.objective.total < start.objective.total


def test_a_part_short_of_its_bound_samples_orders_around_its_plan() -> None:
    """Tests that a large part whose plan still leaves out a whole task
    more than the kept-set bound tries list schedules of orders around
    it before the neighbourhood search, keeps a better one and says how
    much less it leaves out: a broad 36-task day of every resource kind
    over H = 500 (a battery among them), from the start heuristic's
    plan (34 schedule cost units left out, 4 fewer after the orders),
    the disjunctive relaxation kept out (its rounds are timed) so that
    the orders run from the plan the insertion leaves. In the solve at
    5 s, with the relaxation, the orders took this day from 21 units
    left out to 19 (955,833 -> 866,980)."""
    problem = problem_from(
        bench_lib("broad").generate_problem(36, "all", 500, 41)
    )
    domains = start_domains(problem)
    start = greedy_plan(problem, domains=domains)
    assert start is not None and start.objective is not None
    assert start.objective.unscheduled_cost == 34
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    plan = large.improved(
        problem,
        start,
        domains,
        run,
        time.perf_counter(),
        5.0,
        relax_min_s=math.inf,
    )
    assert plan.stats is not None and plan.objective is not None
    said = plan.stats.solver_status
    assert "orders around it sampled (" in said, said
    gained = said.split("orders around it sampled (")[1].split(" ")[0]
    assert gained.isdigit() and int(gained) >= 1, said
    assert check_plan(problem, plan).ok
    assert plan.objective.unscheduled_cost <= 34 - int(gained)


def test_the_best_start_is_chosen_after_insertion() -> None:
    """Tests that of several start plans the one that is best once
    left-out tasks are inserted into each is kept, not the best before:
    the large suite's b45-h2880 of seed 214, whose relaxed kept set
    list-scheduled (12.54 M) is below the start heuristic's plan (13.97
    M), which insertion takes lower (9.69 M against 10.76 M)."""
    problem = large_suite_problem(214, "b45-h2880")
    domains = start_domains(problem)
    start = greedy_plan(problem, domains=domains)
    assert start is not None and start.objective is not None
    relaxed = kept_set_bound(problem, start, domains)
    starts = kept_set_starts(problem, relaxed, thorough=True)
    assert starts
    first = min(starts, key=lambda p: p.objective.total if p.objective else 0)
    assert first.objective is not None
    assert first.objective.total < start.objective.total
    deadline = time.perf_counter() + 60.0
    best, count = large.best_inserted(
        problem, [first, start], domains, deadline
    )
    alone = large.inserting(problem, first, domains, deadline)
    assert best.objective is not None and alone.objective is not None
    assert best.objective.total < alone.objective.total
    assert best == large.inserting(problem, start, domains, deadline)
    assert count == len(start.unscheduled) - len(best.unscheduled) > 0
    assert check_plan(problem, best).ok


def test_a_replan_inserts_a_new_task_the_repair_left_out() -> None:
    """Tests that a replan whose repair leaves the new task out (no gap
    in its window: ``b``, worth 5, can only run first, where the plan in
    force has ``a00``) gets it back by moving the task in its way, and
    says so."""
    problem, in_force = _first_place_taken()
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    plan = replanning.replanned(
        problem,
        in_force,
        start_domains(problem),
        run,
        time.perf_counter(),
        2.0,
    )
    assert plan is not None and plan.stats is not None
    assert "1 left-out tasks inserted" in plan.stats.solver_status, plan.stats
    assert plan.unscheduled == ()
    assert plan.starts()["b"] == 0
    assert check_plan(problem, plan).ok


def _answered(plan: Plan, bound: float) -> Plan:
    """``plan`` as a replan's answer with ``bound`` in its statistics."""
    return plan.replace(
        status=SolveStatus.FEASIBLE,
        stats=SolverStats(solver="cbc-repair", bound=bound, solver_status="r"),
    )


def test_a_replan_that_may_leave_out_a_task_too_many_gets_a_second_look() -> (
    None
):
    """Tests that a replan whose gap is at least the weight of a schedule
    cost unit is solved afresh in what is left of the full limit, and the
    better plan (here the fresh one, holding ``b``) is the answer, with
    why; a gap of delay alone, or no full limit, answers as it was."""
    problem, in_force = _first_place_taken()
    best = solve(problem, time_limit=20)
    assert best.status is SolveStatus.OPTIMAL and best.objective is not None
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    domains = start_domains(problem)
    answer = _answered(in_force, best.objective.total)
    began = time.perf_counter()
    looked = replanning._second_look(problem, answer, domains, run, began, 8.0)
    assert looked.stats is not None
    assert (
        "a whole task may be left out too many" in looked.stats.solver_status
    )
    assert "its plan kept" in looked.stats.solver_status
    assert looked.unscheduled == ()
    # The start heuristic's plan holds ``b``: the search starts from it.
    assert "from the start heuristic's plan" in looked.stats.solver_status
    assert looked.objective is not None and answer.objective is not None
    assert looked.objective.total < answer.objective.total
    assert check_plan(problem, looked).ok
    assert time.perf_counter() - began < 8.0
    # Within one unit's weight of its bound: only delay left to gain.
    assert answer.objective is not None
    close = _answered(in_force, answer.objective.total - 1)
    assert replanning._second_look(
        problem, close, domains, run, began, 8.0
    ) is (close)
    assert replanning._second_look(
        problem, answer, domains, run, began, None
    ) is (answer)
    # A replan's plan better than the heuristic's is where the search
    # starts (here the optimum, its bound set a task too low): nothing
    # better is found, and the replan's plan stays the answer.
    low = best.objective.total - 2 * objective_weight(
        [t.delay_cost for t in problem.tasks], problem.horizon
    )
    optimal = _answered(best, low)
    again = replanning._second_look(
        problem, optimal, domains, run, time.perf_counter(), 8.0
    )
    assert again.stats is not None
    assert "from the replan's plan: no better" in again.stats.solver_status
    assert again.starts() == best.starts()


def test_a_search_left_with_too_little_for_the_whole_model_goes_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that when the search stops with time left but under the
    whole model's minimum, the search goes on to the deadline instead of
    answering with the time unused: here the first search is cut to half
    a second and the minimum raised past the limit."""
    real = large.improve
    calls: list[float] = []

    def first_cut_short(*args: object, **kwargs: object) -> object:
        calls.append(kwargs.get("hand_over_s", 0.0))  # type: ignore[arg-type]
        if len(calls) == 1:
            args = (*args[:4], time.perf_counter() + 0.5, *args[5:])
        return real(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(large, "FULL_MIN_S", 100.0)
    monkeypatch.setattr(large, "improve", first_cut_short)
    problem = problem_from(bench_lib("fresh").generate_problem(30, 2880, 7003))
    began = time.perf_counter()
    plan = solve(problem, time_limit=5)
    wall = time.perf_counter() - began
    assert plan.stats is not None and plan.objective is not None
    assert check_plan(problem, plan).ok
    if plan.status is SolveStatus.FEASIBLE:
        assert calls[-1] == float("inf"), calls
        assert " more" in plan.stats.solver_status, plan.stats
        assert wall >= 0.75 * 5, plan.stats


def test_a_replan_whose_search_ends_early_runs_the_small_whole_model() -> None:
    """Tests that a replan whose neighbourhoods run out with the gap open
    and time left runs the whole model narrowed around its plan when that
    is small, and proves it (replan suite, seed 52's r45-h1440-1: the
    replan answered ``feasible`` after 0.6 s with a gap of 794, the fresh
    solve proved the same plan in 0.15 s this way)."""
    limit = 10.0
    new_problem, plan, _ = _replan_suite_case(52, "r45-h1440-1", limit)
    assert check_plan(new_problem, plan).ok
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "the whole model, narrowed: Optimal" in plan.stats.solver_status
    assert plan.stats.wall_s < BUDGET.replan_limit(limit)


def test_a_part_too_long_for_cbc_in_the_time_left_is_searched() -> None:
    """Tests that a part under 30 tasks whose whole model is too long for
    CBC to start in the time left (the large suite's f30-h2880 of seed 69:
    a 28-task part over H = 2880, 39,661 columns after its rounds) gets
    the neighbourhood search from its plan instead: the solve kept its
    start plan, 9,032 above CP-SAT's optimum, with "time limit spent
    before CBC started". From the start heuristic's plan of the whole
    problem (56,194 columns), 3 s of search gain on it, every plan
    checked; with most of the limit left, the whole model as before."""
    problem = decode_problem(
        (
            Path(__file__).parent / "data" / "long-part-f30-h2880.json"
        ).read_bytes()
    )
    domains = start_domains(problem)
    assert start_count(domains) >= LONG_COLUMNS
    start = greedy_plan(problem)
    assert start is not None and start.objective is not None
    run = functools.partial(solve_ilp, solver="cbc", threads=1)
    # As after rounds that took 6 s of a 9 s limit.
    began = time.perf_counter() - 6.0
    plan = finished(problem, run, start, domains, domains, began, 9.0, None)
    assert plan.objective is not None and check_plan(problem, plan).ok
    assert plan.objective.total < start.objective.total
    assert plan.stats is not None
    assert "neighbourhood search" in plan.stats.solver_status
    # Rounds that ended early leave the whole model its time, as before.
    began = time.perf_counter()
    plan = finished(problem, run, start, domains, domains, began, 1.0, None)
    assert plan.stats is not None
    assert "neighbourhood search" not in plan.stats.solver_status
