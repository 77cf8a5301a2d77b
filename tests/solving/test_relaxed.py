"""Tests of the disjunctive relaxation with level rows (relaxed.py)."""

from __future__ import annotations

import functools
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from hypothesis import HealthCheck, assume, given, settings

from fsw_scheduler.analysis.bounds import kept_set_bound, kept_set_plan
from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.insert import inserted
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving import relaxed
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.incumbent import narrow, probed
from fsw_scheduler.solving.relaxed import (
    RelaxedModel,
    applies,
    around,
    relaxed_bound,
)
from fsw_scheduler.solving.solve import best_start, solve

from ..factories import bench_lib, make_doc, make_task, problem_from
from ..problems import COMMON, decode_doc, mission_docs, problem_docs, show

if TYPE_CHECKING:
    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.model.problem import Problem

CAM_AND_BATTERY = {"binary": ["cam"], "consumable": {"battery": 5}}


def _optimum(doc: dict) -> int:
    """The proved optimum of ``doc`` by the time-indexed model."""
    plan = solve_ilp(problem_from(doc), formulation="time-indexed")
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.objective is not None
    return plan.objective.total


def test_a_valid_relaxed_optimum_is_the_parts_optimum() -> None:
    """Tests that when the relaxation's optimum keeps the battery it is
    returned as the part's optimum, and that its bound sees the camera
    the kept-set bound ignores."""
    doc = make_doc(
        [
            make_task("a", 3, uses={"cam": 1, "battery": 1}),
            make_task("b", 3, uses={"cam": 1}),
            make_task("c", 2, uses={"battery": 1}),
        ],
        horizon=12,
        resources=CAM_AND_BATTERY,
    )
    problem = problem_from(doc)
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None
    answer = relaxed_bound(problem, start, domains, time_limit=None)
    assert answer.plan is not None
    assert answer.plan.status is SolveStatus.OPTIMAL
    assert answer.plan.objective is not None
    assert answer.plan.objective.total == _optimum(doc) == 3
    assert check_plan(problem, answer.plan).ok
    kept = kept_set_bound(problem, start, domains)
    assert kept.bound is not None
    assert answer.bound == 3 > kept.bound


def test_a_relaxed_optimum_that_breaks_a_consumable_is_a_bound_only(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that a relaxed optimum running a consumer before the charge
    it needs is not taken as a plan, and that its bound stays below the
    optimum; with its levels written on the starts the next optimum is
    the part's."""
    doc = _charge_first()
    problem = problem_from(doc)
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None
    monkeypatch.setattr(relaxed, "MAX_LEVEL_ROUNDS", 0)
    answer = relaxed_bound(problem, start, domains, time_limit=None)
    assert answer.plan is None
    assert answer.bound == 0 < _optimum(doc) == 1
    monkeypatch.undo()
    answer = relaxed_bound(problem, start, domains, time_limit=None)
    assert answer.plan is not None and answer.plan.objective is not None
    assert answer.plan.objective.total == answer.bound == 1
    assert answer.levels


def _charge_first() -> dict:
    """A consumer that needs the charge before it (the store is empty)."""
    return make_doc(
        [
            make_task("charge", 2, uses={"battery": -3}),
            make_task("use", 1, uses={"battery": 4}, schedule_cost=0),
            make_task("a", 1, uses={"cam": 1}),
        ],
        horizon=10,
        resources={"binary": ["cam"], "consumable": {"battery": 0}},
    )


def test_tasks_told_apart_only_by_a_consumable_are_not_twins() -> None:
    """Tests that two tasks that differ only in their battery use get no
    symmetry rows: the first, which the battery cannot carry beside a
    costlier task, would otherwise keep the second out and lift the
    bound above the optimum."""
    doc = make_doc(
        [
            make_task("heavy", 2, uses={"cam": 1, "battery": 2}),
            make_task("light", 2, uses={"cam": 1}),
            make_task("other", 2, uses={"battery": 1}, schedule_cost=5),
        ],
        horizon=8,
        resources=CAM_AND_BATTERY,
    )
    problem = problem_from(doc)
    domains = start_domains(problem)
    assert RelaxedModel(problem, domains).constraints.twins == []
    start = best_start(problem, None, domains=domains)
    assert start is not None
    answer = relaxed_bound(problem, start, domains, time_limit=None)
    assert answer.plan is not None
    assert answer.plan.unscheduled == ("heavy",)
    assert answer.bound == _optimum(doc)


def _bound_at_most_the_optimum(doc: dict) -> None:
    """The relaxation's bound on ``doc`` at most the time-indexed model's
    optimum, and a plan it proves valid and optimal (examples the
    relaxation does not apply to, or without a start plan or a proved
    optimum, are discarded)."""
    problem = decode_doc(doc)
    domains = start_domains(problem)
    assume(applies(problem, domains))
    exact = solve_ilp(problem, formulation="time-indexed")
    assume(exact.status is SolveStatus.OPTIMAL)
    assert exact.objective is not None
    start = best_start(problem, None, domains=domains)
    assume(start is not None)
    assert start is not None
    answer = relaxed_bound(problem, start, domains, time_limit=None)
    assert answer.bound is not None
    assert answer.bound <= exact.objective.total + 1e-6, show(doc, exact)
    if answer.plan is not None:
        assert answer.plan.objective == exact.objective, show(doc, exact)
        assert check_plan(problem, answer.plan).ok
    if answer.better is not None:
        assert check_plan(problem, answer.better).ok


@settings(COMMON, max_examples=80)
@given(doc=problem_docs(capacities=True))
def test_the_relaxation_never_bounds_above_the_optimum(doc: dict) -> None:
    """Tests that on small drawn problems with a consumable and a binary
    or multiple resource the relaxation's bound is at most the optimum,
    and a plan it proves is valid and optimal."""
    _bound_at_most_the_optimum(doc)


@settings(
    COMMON,
    max_examples=60,
    suppress_health_check=[HealthCheck.filter_too_much],
)
@given(doc=mission_docs(max_tasks=5, max_horizon=8))
def test_the_relaxation_of_the_mission_model_never_bounds_above_the_optimum(
    doc: dict,
) -> None:
    """Tests the same on days whose camera has windows, whose multiple
    resource has capacity steps (held by pinned blocks in the
    disjunctive model), whose battery is charged or drained from outside
    (its level rows add what came in) and with a group of alternatives
    (the model's group rows; the level rows bind any plan)."""
    _bound_at_most_the_optimum(doc)


def test_the_relaxation_applies_to_mixed_parts_only() -> None:
    """Tests that the relaxation is built only for parts that use a
    consumable and a binary or multiple resource."""

    def applies_to(*tasks: dict) -> bool:
        problem = problem_from(
            make_doc(list(tasks), resources=CAM_AND_BATTERY)
        )
        return applies(problem, start_domains(problem))

    assert applies_to(
        make_task("a", uses={"cam": 1}), make_task("b", uses={"battery": 1})
    )
    assert not applies_to(make_task("a", uses={"battery": 1}))
    assert not applies_to(make_task("a", uses={"cam": 1}))


def test_a_large_fresh_part_is_proved_by_the_relaxation() -> None:
    """Tests that the 28-task part of the large suite's f30-h1440 (seed
    53), whose time-indexed model took CBC 15 s, is proved by the
    relaxation, and the whole problem is optimal."""
    generator = bench_lib("generator")
    bench = next(b for b in generator.large_suite(53) if b.name == "f30-h1440")
    problem = bench.problem()
    plan = solve(problem, time_limit=20)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "relaxation's optimum is a valid plan" in plan.stats.solver_status
    assert check_plan(problem, plan).ok


def test_a_large_part_under_a_short_limit_is_proved_by_the_relaxation() -> (
    None
):
    """Tests that a part of under 30 tasks with over 5,000 columns, under
    a limit too short for the relaxation's usual 5 s minimum (4 s, as a
    replan's 2 s), still goes to the relaxation first and is proved by
    it (the replan suite's seed 17 r30-h1440-1)."""
    generator = bench_lib("generator")
    own = generator.problem_seed(17, "r30-h1440-1")
    problem = problem_from(bench_lib("fresh").generate_problem(30, 1440, own))
    plan = solve(problem, time_limit=4.0)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "relaxation's optimum is a valid plan" in plan.stats.solver_status
    assert check_plan(problem, plan).ok


def test_probing_proves_a_broad_part_within_one_round() -> None:
    """Tests that the relaxation of the large suite's b30-h1440 of seed 71
    (CP-SAT's optimum 3,522,040 in 0.5 s; 20 s of search had left the
    product 71 delay units above it) proves the optimum within one
    round's node limit from the start plan, with CBC's probing on
    (without it, 4,291 nodes): CBC restarts with its probing cuts, which
    is no proof (:func:`~fsw_scheduler.solving.ilp.cbclog.
    restarted_with_cuts`), and the run that confirms its answer without
    the restart proves it."""
    generator = bench_lib("generator")
    bench = next(b for b in generator.large_suite(71) if b.name == "b30-h1440")
    problem = bench.problem()
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None
    start = inserted(problem, start, domains)
    run = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)
    answer = around(
        problem,
        start,
        narrow(problem, start, domains),
        run,
        60,
        probing=True,
    )
    assert answer.plan is not None, answer.said
    assert "again without the restart: Optimal" in answer.said
    assert answer.plan.objective is not None
    assert answer.plan.objective.total == 3_522_040
    assert check_plan(problem, answer.plan).ok


def test_a_fresh_part_needs_time_for_the_relaxation_by_its_size() -> None:
    """Tests that a fresh large part runs the relaxation from a minimum
    left that grows with its tasks (0.09 s each, 1 s to 5 s): a 30-task
    part from 2.7 s left, a 40-task one from 3.6 s, 56 tasks and more
    only from 5 s."""
    from fsw_scheduler.solving.relaxed import fresh_min_left

    def sized(count: int) -> Problem:
        return problem_from(
            make_doc([make_task(f"t{i}", 2) for i in range(count)], 200)
        )

    assert fresh_min_left(sized(5)) == 1.0
    assert fresh_min_left(sized(30)) == pytest.approx(2.7)
    assert fresh_min_left(sized(40)) == pytest.approx(3.6)
    assert fresh_min_left(sized(56)) == 5.0
    assert fresh_min_left(sized(200)) == 5.0


def _campaign_problem(seed: int, style: str, name: str) -> Problem:
    generator = bench_lib("generator")
    bench = next(b for b in generator.campaign(seed, style) if b.name == name)
    return bench.problem()


def test_a_small_mixed_part_is_proved_by_the_relaxation() -> None:
    """Tests that a 15-task part with a battery beside binary and multiple
    resources (broad campaign, seed 81, b15-all-4: the time-indexed model
    took 0.6 s) goes to the relaxation before the time-indexed model and
    is proved by it, with the time-indexed model's optimum."""
    problem = _campaign_problem(81, "broad", "b15-all-4")
    plan = solve(problem, time_limit=30)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "relaxation's optimum is a valid plan" in plan.stats.solver_status
    assert check_plan(problem, plan).ok
    assert plan.objective is not None
    whole = solve_ilp(problem, formulation="time-indexed")
    assert whole.status is SolveStatus.OPTIMAL
    assert whole.objective is not None
    assert plan.objective.total == whole.objective.total == 307_185


def test_a_small_part_the_battery_decides_is_proved_by_its_levels() -> None:
    """Tests that where the relaxation's first optimum breaks the battery
    (paper campaign, seed 81, c15-all-3) the levels written where it
    went below zero make the next optimum the part's."""
    problem = _campaign_problem(81, "paper", "c15-all-3")
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None
    answer = relaxed_bound(problem, start, domains, time_limit=None)
    assert answer.levels
    assert answer.plan is not None and answer.plan.objective is not None
    assert answer.plan.objective.total == answer.bound == 4_322
    # A solve gives a part this small one run with levels
    # (relaxed.SMALL_LEVEL_ROUNDS), then its time-indexed model.
    once = relaxed_bound(
        problem, start, domains, time_limit=None, level_rounds=1
    )
    assert once.plan is None and once.levels
    assert once.bound is not None and once.bound <= 4_322
    plan = solve(problem, time_limit=30)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.objective is not None and plan.objective.total == 4_322
    assert check_plan(problem, plan).ok


def test_a_small_part_the_battery_decides_goes_on_to_the_whole_model(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests that where the relaxation's optimum breaks the battery (paper
    campaign, seed 81, c15-all-3) and no level is written on the starts,
    the part is still proved, by the time-indexed model, with its
    optimum, and that the relaxation's run is bounded by its share of the
    limit."""
    monkeypatch.setattr(relaxed, "MAX_LEVEL_ROUNDS", 0)
    problem = _campaign_problem(81, "paper", "c15-all-3")
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None
    answer = relaxed_bound(problem, start, domains, time_limit=None)
    assert answer.plan is None
    plan = solve(problem, time_limit=30)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "relaxation's optimum" not in plan.stats.solver_status
    assert plan.objective is not None
    assert answer.bound is not None
    assert answer.bound <= plan.objective.total == 4_322
    assert check_plan(problem, plan).ok


#: ``tools/fuzz`` seed 64078: 6 tasks on two cameras, a power line and a
#: battery, a group of two options; CP-SAT's optimum 130,911.
SHORT_ALL = Path(__file__).parent / "data" / "short-all-f64078.json"


@pytest.mark.parametrize(
    ("name", "limit", "optimum"),
    [("b15-all-4", 1.0, 307_185), ("f64078", 0.45, 130_911)],
)
def test_a_small_mixed_part_is_proved_so_under_a_short_limit(
    name: str, limit: float, optimum: int
) -> None:
    """Tests that under a short limit a small part still goes to the
    relaxation, which proves it: at 1 s its rounds get the time CBC needs
    to start (their 0.3 share of what is left would be under CBC's
    minimum: b15-all-4 of broad seed 81, ``feasible`` with the share
    alone, 4 delay units above); with under 0.6 s left they still run
    before the time-indexed model (``tools/fuzz`` seed 64078: at 0.3 s
    ``feasible`` before, CBC's cuts cut off valid plans and the rest of
    its time was gone)."""
    problem = (
        decode_problem(SHORT_ALL.read_bytes())
        if name == "f64078"
        else _campaign_problem(81, "broad", name)
    )
    plan = solve(problem, time_limit=limit)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.stats is not None
    assert "relaxation's optimum is a valid plan" in plan.stats.solver_status
    assert plan.objective is not None
    assert plan.objective.total == optimum
    assert check_plan(problem, plan).ok


def test_no_probe_follows_a_small_parts_relaxation() -> None:
    """Tests that after the relaxation's rounds on a small part whose
    relaxed optimum breaks the battery (paper seed 91's c15-all-6, whose
    start plan leaves out a task more than the bound) no probe of the
    time-indexed model is run: the full run starts from the rounds'
    incumbent (a probe there took 7.7 s and was thrown away)."""
    problem = _campaign_problem(91, "paper", "c15-all-6")
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None
    relaxed = kept_set_plan(problem, start, domains)
    narrowed = narrow(problem, start, domains, relaxed)
    runs: list[str] = []

    def run(problem: Problem, **options: Any) -> Plan:
        plan = solve_ilp(problem, solver="cbc", threads=1, seed=0, **options)
        runs.append(plan.stats.solver_status if plan.stats else "")
        return plan

    run_it = functools.partial(run)
    answer, incumbent, _, bound = probed(
        problem,
        run_it,
        start,
        domains,
        narrowed,
        relaxed,
        time.perf_counter(),
        30.0,
    )
    assert answer is None
    assert runs == [], runs
    assert bound is not None and incumbent is not None
    assert incumbent.objective is not None
    assert bound <= 46_716 <= incumbent.objective.total


#: ``tools/fuzz`` seed 68044: 19 tasks on two power lines and a battery;
#: CP-SAT's optimum 79,974.
RESTARTED = Path(__file__).parent / "data" / "restart-f68044.json"


def test_the_relaxation_with_probing_proves_no_wrong_optimum() -> None:
    """Tests that the relaxation's rounds with probing give the true
    optimum: CBC restarted on a reduced model that kept its probing cuts
    and proved 79,990 optimal (the product answered ``optimal`` with it
    at 60 s and in one run at 20 s); without the restart (``strategy
    0``) the same rounds prove 79,974, CP-SAT's optimum."""
    problem = decode_problem(RESTARTED.read_bytes())
    plan = solve(problem, time_limit=60)
    assert plan.objective is not None
    assert check_plan(problem, plan).ok
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.objective.total == 79_974


def test_a_confirming_run_keeps_probing() -> None:
    """Tests that the run confirming an optimum CBC claimed after its
    restart keeps probing on (CBC reads "strategy 0" as probing off where
    cuts are off, so it goes first): the largest part of the orbit
    suite's of45-h2880 of seed 210 (42 tasks; CP-SAT's optimum 25,364,074
    in 7.5 s) went unconfirmed in 8,000 nodes without probing; with it
    the second round's optimum is confirmed in a few hundred nodes."""
    generator = bench_lib("generator")
    bench = next(
        b for b in generator.orbit_suite(210) if b.name == "of45-h2880"
    )
    whole = bench.problem()
    plan = solve(whole, time_limit=40)
    assert plan.stats is not None
    assert "again without the restart: Optimal" in plan.stats.solver_status
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.objective is not None
    assert plan.objective.total == 25_364_074
    assert check_plan(whole, plan).ok
