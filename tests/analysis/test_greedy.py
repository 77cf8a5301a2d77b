"""Tests of the list-scheduling heuristic (fsw_scheduler.analysis.greedy)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import pytest
from hypothesis import given, settings

from fsw_scheduler.analysis.bounds import at_lower_bound
from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import bundles, greedy_plan
from fsw_scheduler.analysis.proofs import forced_tasks
from fsw_scheduler.analysis.sampling import (
    AROUND_ORDERS,
    BETTER_ORDERS,
    SAMPLED_ORDERS,
    sampled_around,
    sampled_better,
    sampled_plan,
)
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving.solve import best_start, solve

from ..factories import bench_lib, large_suite_problem, make_task, problem_from
from ..problems import COMMON, brute_force, decode_doc, problem_docs
from .fresh import fresh_doc

if TYPE_CHECKING:
    from collections.abc import Callable

    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.model.problem import Problem


def test_table1_greedy_is_valid(table1: Problem) -> None:
    """Tests that the heuristic finds a valid Table 1 plan quickly."""
    plan = greedy_plan(table1)
    assert plan is not None
    assert plan.status is SolveStatus.FEASIBLE
    assert check_plan(table1, plan).ok
    assert plan.unscheduled == ()


def test_tight_group_members_share_a_consumable() -> None:
    """Tests that tight partners are checked together on a consumable."""
    doc = {
        "horizon": 10,
        "resources": {"consumable": {"fuel": 5}},
        "tasks": [
            {
                "id": "a",
                "length": 2,
                "delay_cost": 1,
                "schedule_cost": 1,
                "uses": {"fuel": 2},
            },
            {
                "id": "b",
                "length": 2,
                "delay_cost": 1,
                "schedule_cost": 1,
                "uses": {"fuel": 2},
            },
        ],
        "precedences": [{"before": "a", "after": "b", "kind": "tight"}],
    }
    problem = problem_from(doc)
    plan = greedy_plan(problem)
    # Each alone fits (4 <= 5) but not both (8 > 5): both stay out.
    assert plan is not None
    assert sorted(plan.unscheduled) == ["a", "b"]


def test_optional_follower_is_shed_when_the_group_cannot_fit() -> None:
    """Tests that a tight at_least_first successor does not sink its lead.

    ``a`` fits alone, but its tight successor ``b`` would need fuel that
    is not there: ``a`` is placed without it.
    """
    doc = {
        "horizon": 10,
        "resources": {"consumable": {"fuel": 5}},
        "tasks": [
            {
                "id": "a",
                "length": 2,
                "delay_cost": 1,
                "schedule_cost": 5,
                "uses": {"fuel": 2},
            },
            {
                "id": "b",
                "length": 2,
                "delay_cost": 1,
                "schedule_cost": 1,
                "uses": {"fuel": 2},
            },
        ],
        "precedences": [
            {
                "before": "a",
                "after": "b",
                "kind": "tight",
                "scope": "at_least_first",
            }
        ],
    }
    problem = problem_from(doc)
    plan = greedy_plan(problem)
    assert plan is not None
    assert plan.unscheduled == ("b",)
    assert check_plan(problem, plan).ok


def test_a_group_cut_by_shedding_is_placed_in_its_parts() -> None:
    """Tests that shedding a follower that tied two tasks frees them.

    ``f`` follows ``long`` and ``short`` tightly, which puts ``short``
    inside ``long`` on the antenna: ``f`` is impossible, and without it
    ``long`` and ``short`` are no longer tied, so each is placed (the
    start plan of broad seed 15's b15-all-6 left a whole chain out this
    way, 4x its optimum).
    """
    doc = {
        "horizon": 30,
        "resources": {"binary": ["antenna"]},
        "tasks": [
            {
                "id": "long",
                "length": 10,
                "delay_cost": 1,
                "schedule_cost": 5,
                "uses": {"antenna": 1},
            },
            {
                "id": "short",
                "length": 2,
                "delay_cost": 1,
                "schedule_cost": 5,
                "uses": {"antenna": 1},
            },
            {"id": "f", "length": 3, "delay_cost": 1, "schedule_cost": 1},
        ],
        "precedences": [
            {
                "before": "long",
                "after": "f",
                "kind": "tight",
                "scope": "at_least_first",
            },
            {
                "before": "short",
                "after": "f",
                "kind": "tight",
                "scope": "at_least_first",
                "offset": 3,
            },
        ],
    }
    problem = problem_from(doc)
    plan = greedy_plan(problem)
    assert plan is not None
    assert check_plan(problem, plan).ok
    assert plan.unscheduled == ("f",)
    best = solve(problem).objective
    assert best is not None and plan.objective is not None
    assert plan.objective.unscheduled_cost == best.unscheduled_cost


def test_density_rule_spends_a_consumable_on_value() -> None:
    """Tests that the best of the priority rules is kept.

    By value the big consumer ``big`` (cost 5) goes first and uses all the
    fuel; by value per fuel share the two small ones (cost 4 each) fit.
    """

    def task(name: str, cost: int, fuel: int) -> dict:
        return {
            "id": name,
            "length": 1,
            "delay_cost": 1,
            "schedule_cost": cost,
            "uses": {"fuel": fuel},
        }

    doc = {
        "horizon": 10,
        "resources": {"consumable": {"fuel": 6}},
        "tasks": [task("big", 5, 6), task("s1", 4, 3), task("s2", 4, 3)],
    }
    problem = problem_from(doc)
    plan = greedy_plan(problem)
    assert plan is not None and plan.objective is not None
    assert plan.unscheduled == ("big",)
    assert plan.objective.unscheduled_cost == 5


def test_deadline_rule_keeps_narrow_windows_free() -> None:
    """Tests that a wide-window task does not take a narrow one's slot.

    By value ``wide`` (cost 5) goes first, at 0, and ``narrow`` (which
    must start at 0) is out; earliest deadline first fits both.
    """
    doc = {
        "horizon": 4,
        "resources": {"binary": ["cam"]},
        "tasks": [
            {
                "id": "wide",
                "length": 2,
                "delay_cost": 1,
                "schedule_cost": 5,
                "uses": {"cam": 1},
            },
            {
                "id": "narrow",
                "length": 2,
                "delay_cost": 1,
                "schedule_cost": 4,
                "uses": {"cam": 1},
                "feasible_interval": [0, 0],
                "feasible_interval_applies_to": "start",
            },
        ],
    }
    problem = problem_from(doc)
    plan = greedy_plan(problem)
    assert plan is not None
    assert plan.unscheduled == ()
    assert plan.starts() == {"narrow": 0, "wide": 2}


def test_impossible_mandatory_gives_none() -> None:
    """Tests that the heuristic gives up when a mandatory task can't fit."""
    doc = {
        "horizon": 4,
        "resources": {"binary": ["cam"]},
        "tasks": [
            {
                "id": n,
                "length": 3,
                "delay_cost": 1,
                "schedule_cost": 0,
                "uses": {"cam": 1},
            }
            for n in ("a", "b")
        ],
    }
    assert greedy_plan(problem_from(doc)) is None


def test_lower_bound_shortcut_is_optimal() -> None:
    """Tests that a plan at every earliest start is reported optimal."""
    doc = {
        "horizon": 10,
        "tasks": [
            {
                "id": "a",
                "length": 2,
                "delay_cost": 3,
                "schedule_cost": 1,
                "feasible_interval": [3, 9],
            },
        ],
    }
    problem = problem_from(doc)
    start = best_start(problem, None)
    assert start is not None and at_lower_bound(problem, start)
    plan = solve(problem)
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.starts() == {"a": 3}
    assert plan.stats is not None and plan.stats.solver == "greedy"


@settings(COMMON, max_examples=300)
@given(doc=problem_docs())
def test_greedy_plans_pass_the_checker(doc: dict) -> None:
    """Tests that every heuristic plan passes the independent checker."""
    problem = decode_doc(doc)
    plan = greedy_plan(problem)
    if plan is not None:
        report = check_plan(problem, plan)
        assert report.ok, report
        assert plan.objective == report.objective


@settings(COMMON, max_examples=150)
@given(doc=problem_docs(max_tasks=4, max_horizon=8))
def test_lower_bound_shortcut_agrees_with_brute_force(doc: dict) -> None:
    """Tests that the no-solver optimality shortcut is never wrong."""
    problem = decode_doc(doc)
    start = best_start(problem, None)
    if start is None or not at_lower_bound(problem, start):
        return
    best = brute_force(problem)
    assert best is not None
    assert start.objective is not None
    assert start.objective.total == best[0].total


def _needs_optional_first() -> Problem:
    """Mandatory ``m`` needs optional ``p`` (so ``p`` is forced); ``x`` is
    worth more than ``p`` and, placed first, takes every slot ``m`` has."""
    return problem_from(
        {
            "horizon": 12,
            "resources": {"binary": ["r"]},
            "tasks": [
                {
                    "id": "m",
                    "length": 5,
                    "delay_cost": 1,
                    "schedule_cost": 0,
                    "uses": {"r": 1},
                    "feasible_interval": [5, 12],
                },
                {"id": "p", "length": 3, "delay_cost": 1, "schedule_cost": 1},
                {
                    "id": "x",
                    "length": 8,
                    "delay_cost": 5,
                    "schedule_cost": 5,
                    "uses": {"r": 1},
                },
            ],
            "precedences": [
                {
                    "before": "p",
                    "after": "m",
                    "kind": "lax",
                    "scope": "at_least_first",
                }
            ],
        }
    )


def test_start_plan_never_worse_than_the_trivial_plan() -> None:
    """Tests that the start plan exists when the forced tasks fit alone.

    Every priority rule used to place ``x`` before ``m`` was ready and
    then found no slot for ``m``: no start plan at all, although ``p``
    and ``m`` alone make a valid plan.
    """
    problem = _needs_optional_first()
    plan = greedy_plan(problem)
    assert plan is not None
    assert check_plan(problem, plan).ok
    assert plan.starts() == {"p": 0, "m": 5}


def test_stop_keeps_the_trivial_plan() -> None:
    """Tests that a heuristic stopped at once still returns the plan of the
    forced tasks alone."""
    problem = _needs_optional_first()
    plan = greedy_plan(problem, stop=lambda: True)
    assert plan is not None
    assert check_plan(problem, plan).ok
    assert set(plan.starts()) == {"p", "m"}


def test_generators_go_before_a_mandatory_task_that_needs_them() -> None:
    """Tests that a mandatory task needing more than the initial level
    gets a start plan: the generators it needs are placed first."""
    doc = {
        "horizon": 30,
        "resources": {"binary": ["cam"], "consumable": {"battery": 10}},
        "tasks": [
            make_task("draw", 5, schedule_cost=0, uses={"battery": 4}),
            make_task("hog", 5, schedule_cost=5, uses={"battery": 2}),
            make_task("sun", 4, uses={"battery": -3, "cam": 1}),
            make_task("far", 4, uses={"battery": -3}),
        ],
        # far can only charge after draw's latest end: it cannot help.
        "precedences": [{"before": "draw", "after": "far", "kind": "lax"}],
    }
    problem = problem_from(doc)
    plan = greedy_plan(problem)
    assert plan is not None and check_plan(problem, plan).ok
    starts = plan.starts()
    assert starts["sun"] < starts["draw"] + 5  # charging while it runs


@pytest.mark.parametrize("seed", [6, 11, 16, 22, 38, 64])
def test_start_plan_on_feasible_fresh_problems(seed: int) -> None:
    """Tests that fresh-shaped problems CP-SAT solves get a start plan
    that passes the checker (each had none before supply-first)."""
    horizon = (240, 480, 960, 1440)[seed % 4]
    problem = problem_from(fresh_doc(10 + seed % 16, horizon, seed))
    plan = greedy_plan(problem)
    assert plan is not None and check_plan(problem, plan).ok
    reference = bench_lib("cpsat").solve_cpsat(problem, time_limit=20)
    assert reference.status.has_plan


def test_start_plans_of_fresh_problems_pass_the_checker() -> None:
    """Tests that every start plan on fresh-shaped problems (up to 25
    tasks, H up to 1440) passes the independent checker."""
    found = 0
    for seed in range(24):
        horizon = (240, 480, 960, 1440)[seed % 4]
        problem = problem_from(fresh_doc(10 + seed % 16, horizon, seed))
        plan = greedy_plan(problem)
        if plan is not None:
            found += 1
            report = check_plan(problem, plan)
            assert report.ok, (seed, report)
            assert plan.objective == report.objective
    assert found >= 12


#: Ten tasks of the fresh shape, two of them pinned and mandatory (found
#: by a search for problems the rules alone leave without a plan).
PINNED_APART = Path(__file__).with_name("pinned_apart.json")


def test_the_forced_tasks_are_planned_apart_when_no_rule_holds_them() -> None:
    """Tests the heuristic's fallback: on a problem where no rule places
    the tasks every plan must hold among the others, planning those alone
    first and the others around them gives a plan the checker accepts."""
    problem = problem_from(json.loads(PINNED_APART.read_text()))
    assert greedy_plan(problem, apart=False) is None
    plan = greedy_plan(problem)
    assert plan is not None and plan.objective is not None
    assert check_plan(problem, plan).ok
    starts = plan.starts()
    assert starts["T001"] == 9 and starts["T004"] == 2  # the pins


def test_stores_are_charged_first_when_only_optional_tasks_need_it() -> None:
    """Tests that the supply rule also places every task that charges a
    store first, not only those the forced tasks need: the large suite's
    b45-h1440 of seed 197, where generators with early windows lost the
    camera to long tasks worth more and every consumer they feed went
    with them (13 tasks left out, 8.83 M; this way 5, 3.44 M)."""
    problem = large_suite_problem(197, "b45-h1440")
    plan = greedy_plan(problem)
    assert plan is not None and plan.objective is not None
    assert check_plan(problem, plan).ok
    assert len(plan.unscheduled) <= 5
    assert plan.objective.total < 4_000_000


#: The forced core of ``tools/fuzz --large`` seed 1192: its 17 mandatory
#: tasks with the supplies of the two batteries they can run out of (23
#: tasks over H = 700, two cameras, two power resources), as
#: :func:`~fsw_scheduler.solving.forced.forced_start` cuts it.
SAMPLED_CORE = Path(__file__).parent / "forced_core_l1192.json"


def test_perturbed_orders_place_a_core_no_rule_places() -> None:
    """Tests that biased random sampling places the forced core that
    every rule of the list scheduler leaves short: the plan holds every
    mandatory task and the checker accepts it; the same plan every time
    (a seeded generator)."""
    problem = decode_problem(SAMPLED_CORE.read_bytes())
    domains = start_domains(problem)
    assert greedy_plan(problem) is None
    plan = sampled_plan(problem, domains)
    assert plan is not None and plan.status is SolveStatus.FEASIBLE
    assert check_plan(problem, plan).ok
    assert forced_tasks(problem) <= {a.task for a in plan.activities}
    assert sampled_plan(problem) == plan
    other = sampled_plan(problem, seed=7)
    assert other is not None and check_plan(problem, other).ok


def test_sampling_stops_when_asked_and_gives_up_in_bounded_tries() -> None:
    """Tests that sampling returns None at once when time is up, and
    after at most ``SAMPLED_ORDERS`` orders when no order places the
    mandatory tasks (two mandatory tasks that each need the whole
    horizon of one camera)."""
    problem = decode_problem(SAMPLED_CORE.read_bytes())
    assert sampled_plan(problem, stop=lambda: True) is None
    impossible = problem_from(
        {
            "horizon": 10,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task("A", length=6, schedule_cost=0, uses={"camera": 1}),
                make_task("B", length=6, schedule_cost=0, uses={"camera": 1}),
            ],
        }
    )
    asked = []

    def counting() -> bool:
        asked.append(1)
        return False

    assert sampled_plan(impossible, stop=counting) is None
    assert len(asked) == SAMPLED_ORDERS


#: The 40-task part of ``tools/fuzz --large`` seed 1312: a camera, two
#: power lines and a battery of 50 that six short generators refill,
#: over H = 2,880; CP-SAT's optimum 66,876.
BATTERY_ORDER = Path(__file__).parent / "battery_order_l1312.json"


def test_perturbed_orders_better_a_start_the_battery_binds() -> None:
    """Tests that perturbed list-scheduling orders improve the rules' best
    plan of a battery-bound part by far (87,779 before; the search kept
    its arrangement), with a plan the checker accepts, the same every
    time; and that a start nothing beats, or a stop already due, gives
    the start back."""
    problem = decode_problem(BATTERY_ORDER.read_bytes())
    domains = start_domains(problem)
    start = greedy_plan(problem, domains=domains)
    assert start is not None and start.objective is not None
    assert start.objective.total == 87_779
    plan = sampled_better(problem, start, domains)
    assert plan.objective is not None
    assert plan.objective.total < 0.85 * start.objective.total
    assert check_plan(problem, plan).ok
    assert sampled_better(problem, start, domains) == plan
    assert sampled_better(problem, plan, domains, seed=0) is plan
    assert sampled_better(problem, start, domains, stop=lambda: True) is start
    assert _stops_asked(sampled_better, problem, start, domains) == (
        BETTER_ORDERS
    )


def _stops_asked(
    sample: Callable[..., Plan], *args: object, stale: int | None = None
) -> int:
    """How many times ``sample(*args, stop=...)`` asks its ``stop`` (once
    before each order) when it is never told to stop (``stale`` passed
    on when given)."""
    asked = []

    def counting() -> bool:
        asked.append(1)
        return False

    if stale is None:
        sample(*args, stop=counting)
    else:
        sample(*args, stale=stale, stop=counting)
    return len(asked)


def test_orders_around_the_incumbent_keep_more_of_a_battery_day() -> None:
    """Tests that list schedules of orders drawn around the incumbent's,
    re-centred on each better plan, keep what the start heuristic's order
    leaves out on a day a battery binds (a broad 20-task day of every
    resource kind over H = 200: 10 schedule cost units left out by the
    best rule, 2 after the search), with a plan the checker accepts; the
    same plan every time, the start itself when stopped at once, and
    never more orders than :data:`AROUND_ORDERS`."""
    problem = problem_from(
        bench_lib("broad").generate_problem(20, "all", 200, 10)
    )
    domains = start_domains(problem)
    start = greedy_plan(problem, domains=domains)
    assert start is not None and start.objective is not None
    assert start.objective.unscheduled_cost == 10
    plan = sampled_around(problem, start, domains)
    assert plan.objective is not None
    assert plan.objective.unscheduled_cost == 2
    assert plan.objective.total < start.objective.total
    assert check_plan(problem, plan).ok
    assert sampled_around(problem, start, domains) == plan
    assert sampled_around(problem, start, domains, stop=lambda: True) is start
    assert _stops_asked(sampled_around, problem, start, domains) == (
        AROUND_ORDERS
    )


@pytest.mark.parametrize("seed", [0, 3, 6, 8])
def test_orders_around_the_incumbent_never_make_it_worse(seed: int) -> None:
    """Tests that the order search around a plan returns a plan at least
    as good that the checker accepts, from the start heuristic's plan
    and again from its own answer (broad 20-task days of every resource
    kind)."""
    problem = problem_from(
        bench_lib("broad").generate_problem(20, "all", 200, seed)
    )
    domains = start_domains(problem)
    start = greedy_plan(problem, domains=domains)
    assert start is not None and start.objective is not None
    plan = sampled_around(problem, start, domains, orders=30)
    assert plan.objective is not None
    assert plan.objective.total <= start.objective.total
    assert check_plan(problem, plan).ok
    again = sampled_around(problem, plan, domains, orders=30, seed=1)
    assert again.objective is not None
    assert again.objective.total <= plan.objective.total
    assert check_plan(problem, again).ok


def test_a_bundle_every_rule_leaves_out_is_placed_first() -> None:
    """Tests that a bundle of tasks tied by ``both`` and tight precedences
    (kept together or not at all) that every rule leaves out, because
    the tasks every plan must hold took its only camera slots first, is
    placed before every other task: the large suite's b60-h1440 of seed
    210 (60 tasks), 31 tasks left out by every rule (11 of them a
    13-task bundle worth 41 units, which CP-SAT keeps), now at most 22,
    the bundle kept, the plan valid."""
    problem = large_suite_problem(210, "b60-h1440")
    found = [b for b in bundles(problem) if "T051" in b]
    assert len(found) == 1 and len(found[0]) == 13
    plan = greedy_plan(problem)
    assert plan is not None and check_plan(problem, plan).ok
    assert len(plan.unscheduled) <= 22
    assert not found[0] & set(plan.unscheduled)


def test_a_cut_group_is_split_into_its_tight_chains_in_precedence_order() -> (
    None
):
    """Tests that the members of a group that shedding cut in two are
    split into their tight-connected chains, each with its shifts from
    its own first start, the chain another must follow first (a lax
    precedence between them), members in the order of their shifts."""
    from fsw_scheduler.analysis.greedy import _split

    problem = problem_from(
        {
            "horizon": 20,
            "tasks": [make_task(n, 2) for n in ("a", "b", "c", "d")],
            "precedences": [
                {"before": "a", "after": "b", "kind": "tight", "offset": 0},
                {"before": "c", "after": "a", "kind": "lax"},
            ],
        }
    )
    assert _split(problem, {"a": 0, "b": 2, "c": 5}) == [
        {"c": 0},
        {"a": 0, "b": 2},
    ]
    assert _split(problem, {"a": 3, "b": 5}) == [{"a": 3, "b": 5}]
    assert _split(problem, {"d": 4, "b": 1}) == [{"b": 0}, {"d": 0}]


def test_what_no_rule_places_of_the_mandatory_tasks_is_named() -> None:
    """Tests that ``unplaced`` names, for the rules that cannot place
    every mandatory task, the ones each leaves out: two mandatory tasks
    that need the camera over the same ten units cannot both be placed,
    so one of them is named by every rule (each set of one task);
    without the clash every rule places them and nothing is named."""
    from fsw_scheduler.analysis.greedy import unplaced

    def doc(window_b: list[int]) -> dict:
        return {
            "horizon": 30,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task(
                    "a",
                    10,
                    schedule_cost=0,
                    feasible_interval=[0, 10],
                    uses={"camera": 1},
                ),
                make_task(
                    "b",
                    10,
                    schedule_cost=0,
                    feasible_interval=window_b,
                    uses={"camera": 1},
                ),
                make_task("c", 5, uses={"camera": 1}),
            ],
        }

    clash = problem_from(doc([0, 10]))
    found = unplaced(clash)
    assert found and all(len(names) == 1 for names in found)
    assert set().union(*found) <= {"a", "b"}
    assert found == sorted(found, key=lambda n: (len(n), sorted(n)))
    assert unplaced(problem_from(doc([0, 30]))) == []
    # Stopped before any pass ends: nothing named.
    assert unplaced(clash, stop=lambda: True) == []


def test_orders_around_the_incumbent_end_when_they_stop_finding() -> None:
    """Tests that with ``stale`` the orders drawn around the incumbent end
    after that many in a row found nothing better, with the plan the
    same draws give without it (a broad 15-task multiple-resource day,
    the campaign's b15-multiple-3 of seed 241: the rules' plan 92,847;
    the 1st, 2nd and 4th orders are better, the last at CP-SAT's optimum
    92,712; then 30 more)."""
    problem = problem_from(
        bench_lib("broad").generate_problem(15, "multiple", 336, 3645019511)
    )
    domains = start_domains(problem)
    start = best_start(problem, None, domains=domains)
    assert start is not None and start.objective is not None
    assert start.objective.total == 92847
    asked = _stops_asked(sampled_around, problem, start, domains, stale=30)
    assert asked == 4 + 30
    plan = sampled_around(problem, start, domains, stale=30)
    assert plan.objective is not None and plan.objective.total == 92712
    assert check_plan(problem, plan).ok
    assert sampled_around(problem, start, domains, orders=asked) == plan
