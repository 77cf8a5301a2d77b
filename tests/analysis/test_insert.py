"""Tests of inserting left-out tasks by moving what blocks them."""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis import insert
from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import greedy_plan
from fsw_scheduler.analysis.insert import inserted
from fsw_scheduler.model.plan import Activity, SolveStatus

from ..factories import (
    crowded_camera,
    large_suite_problem,
    make_task,
    problem_from,
)
from ..problems import (
    COMMON,
    at_earliest_but,
    decode_doc,
    mission_docs,
    plan_of,
)

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem


def _blocked(**late: object) -> Problem:
    """One camera over 10 units: ``a`` (4 units, any start) and ``b``
    (4 units, worth 3, only at 0); ``late`` overrides ``a``'s fields."""
    return problem_from(
        {
            "horizon": 10,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task("a", 4, uses={"camera": 1}, **late),
                make_task(
                    "b",
                    4,
                    schedule_cost=3,
                    uses={"camera": 1},
                    feasible_interval=[0, 4],
                ),
            ],
        }
    )


def test_a_task_in_the_way_moves_to_make_room() -> None:
    """Tests that a left-out task takes the place of a placed one, which
    goes to its next free start, and that the checker accepts it."""
    problem = _blocked()
    start = plan_of(problem, {"a": 0, "b": None})
    assert start.unscheduled == ("b",)
    better = inserted(problem, start, start_domains(problem))
    assert better.activities == (Activity("b", 0, 4), Activity("a", 4, 8))
    assert better.unscheduled == ()
    assert better.status is SolveStatus.FEASIBLE
    assert check_plan(problem, better).ok
    assert better.objective is not None and start.objective is not None
    assert better.objective.total < start.objective.total


def test_a_required_task_with_nowhere_to_go_stays() -> None:
    """Tests that a move is undone when a mandatory task taken out finds
    no room again: the plan itself comes back."""
    problem = _blocked(schedule_cost=0, feasible_interval=[0, 4])
    start = plan_of(problem, {"a": 0, "b": None})
    assert inserted(problem, start, start_domains(problem)) is start


def test_a_cheaper_task_is_left_out_for_a_dearer_one() -> None:
    """Tests that a blocker with no room left is dropped when that leaves
    out less: ``a`` (worth 1) gives way to ``b`` (worth 3)."""
    problem = _blocked(feasible_interval=[0, 4])
    start = plan_of(problem, {"a": 0, "b": None})
    better = inserted(problem, start, start_domains(problem))
    assert better.activities == (Activity("b", 0, 4),)
    assert better.unscheduled == ("a",)
    assert check_plan(problem, better).ok


def test_a_task_comes_in_with_the_one_its_precedence_needs() -> None:
    """Tests that a left-out task that must follow another left-out one
    is inserted with it, both in order, in one move."""
    problem = problem_from(
        {
            "horizon": 12,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task("a", 4, uses={"camera": 1}),
                make_task("first", 2, schedule_cost=2),
                make_task(
                    "then",
                    4,
                    schedule_cost=3,
                    uses={"camera": 1},
                    feasible_interval=[2, 6],
                ),
            ],
            "precedences": [
                {
                    "before": "first",
                    "after": "then",
                    "kind": "lax",
                    "scope": "both",
                }
            ],
        }
    )
    start = plan_of(problem, {"a": 2, "first": None, "then": None})
    assert set(start.unscheduled) == {"first", "then"}
    better = inserted(problem, start, start_domains(problem))
    assert better.unscheduled == ()
    assert better.starts() == {"first": 0, "then": 2, "a": 6}
    assert check_plan(problem, better).ok


def test_a_generator_taken_out_cannot_starve_a_consumer() -> None:
    """Tests that a move which would leave a consumer without the charge
    of the generator it moved is undone (the levels are checked)."""
    problem = problem_from(
        {
            "horizon": 10,
            "resources": {
                "binary": ["camera"],
                "consumable": {"battery": 0},
            },
            "tasks": [
                make_task(
                    "charge",
                    4,
                    uses={"camera": 1, "battery": -1},
                    feasible_interval=[0, 4],
                ),
                make_task(
                    "use",
                    4,
                    schedule_cost=2,
                    uses={"battery": 1},
                    feasible_interval=[4, 8],
                ),
                make_task(
                    "b",
                    4,
                    schedule_cost=2,
                    uses={"camera": 1},
                    feasible_interval=[0, 4],
                ),
            ],
        }
    )
    start = plan_of(problem, {"charge": 0, "use": 4, "b": None})
    assert start.unscheduled == ("b",)
    assert inserted(problem, start, start_domains(problem)) is start


def test_a_stop_and_the_budget_bound_the_work() -> None:
    """Tests that the caller's deadline returns the plan at once, and
    that at most MAX_TRIES moves are tried however many are left out."""
    problem = _blocked()
    start = plan_of(problem, {"a": 0, "b": None})
    domains = start_domains(problem)
    assert inserted(problem, start, domains, stop=lambda: True) is start
    crowded = problem_from(crowded_camera(500))
    plan = plan_of(
        crowded, {t.id: 0 if t.id == "long" else None for t in crowded.tasks}
    )
    asked = []

    def stop() -> bool:
        asked.append(1)
        return False

    assert inserted(crowded, plan, start_domains(crowded), stop=stop) is plan
    assert len(asked) <= insert.MAX_TRIES


def test_a_broad_start_plan_leaves_out_less() -> None:
    """Tests that on a large broad problem (60 tasks, binary and multiple
    resources, a battery) the start plan gets left-out tasks back: seed
    47's b60-h1440 of the large suite, 26 left out before (27 before
    bundles were tried first: greedy._bundles_first), CP-SAT 17."""
    problem = large_suite_problem(47, "b60-h1440")
    domains = start_domains(problem)
    start = greedy_plan(problem, domains=domains)
    assert start is not None and start.objective is not None
    assert len(start.unscheduled) == 26
    better = inserted(problem, start, domains)
    assert check_plan(problem, better).ok
    assert better.objective is not None
    assert better.objective.total < start.objective.total
    assert len(better.unscheduled) <= 21
    # The same plan again: no clock in the decisions.
    assert inserted(problem, start, domains) == better


def _drawn(dear: int) -> Problem:
    """A battery of 4 over 12 units, no charge: ``cheap`` (worth 1) and
    ``dear`` (worth ``dear``) each draw 1 a unit for 4 units, so only one
    of them can run."""
    return problem_from(
        {
            "horizon": 12,
            "resources": {"consumable": {"battery": 4}},
            "tasks": [
                make_task("cheap", 4, uses={"battery": 1}),
                make_task("dear", 4, schedule_cost=dear, uses={"battery": 1}),
            ],
        }
    )


def test_a_cheap_consumer_gives_its_charge_to_a_dear_one() -> None:
    """Tests that a task short of a consumable gets it from a placed
    consumer worth less, which is left out (nothing blocks it in time:
    the battery is spent over the whole horizon)."""
    problem = _drawn(dear=3)
    start = plan_of(problem, {"cheap": 0, "dear": None})
    better = inserted(problem, start, start_domains(problem))
    assert better.unscheduled == ("cheap",)
    assert better.starts() == {"dear": 0}
    assert check_plan(problem, better).ok


def test_a_consumer_worth_as_much_keeps_its_charge() -> None:
    """Tests that a consumer is not taken out for a task worth no more
    (the move would not lower the objective): the plan comes back."""
    problem = _drawn(dear=1)
    start = plan_of(problem, {"cheap": 0, "dear": None})
    assert inserted(problem, start, start_domains(problem)) is start


def test_a_consumer_is_tried_where_the_charge_is() -> None:
    """Tests that a left-out consumer sharing no resource with a placed
    task is tried at its first fitting start, not only at its window's
    first: an empty battery is charged 1 a unit over units 0-3 and
    ``use`` draws 2 a unit for 2 units, so it fits from 2 on, not at 0."""
    problem = problem_from(
        {
            "horizon": 12,
            "resources": {"consumable": {"battery": 0}},
            "tasks": [
                make_task("charge", 4, uses={"battery": -1}),
                make_task("use", 2, schedule_cost=2, uses={"battery": 2}),
            ],
        }
    )
    start = plan_of(problem, {"charge": 0, "use": None})
    better = inserted(problem, start, start_domains(problem))
    assert better.unscheduled == ()
    assert better.starts() == {"charge": 0, "use": 2}
    assert check_plan(problem, better).ok


def test_a_chain_of_four_comes_in_together() -> None:
    """Tests that four left-out tasks tied by ``both`` precedences (none
    can run without the others) are inserted in one move."""
    names = ["a", "b", "c", "d"]
    problem = problem_from(
        {
            "horizon": 20,
            "resources": {"binary": ["camera"]},
            "tasks": [make_task(n, 2, uses={"camera": 1}) for n in names],
            "precedences": [
                {"before": x, "after": y, "kind": "lax", "scope": "both"}
                for x, y in itertools.pairwise(names)
            ],
        }
    )
    start = plan_of(problem, dict.fromkeys(names))
    better = inserted(problem, start, start_domains(problem))
    assert better.unscheduled == ()
    assert better.starts() == {"a": 0, "b": 2, "c": 4, "d": 6}


def test_five_tasks_in_the_way_make_room() -> None:
    """Tests that a left-out task with five placed tasks in its way (its
    only start) takes their place, each going back later."""
    problem = problem_from(
        {
            "horizon": 30,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task(
                    "long",
                    10,
                    schedule_cost=3,
                    uses={"camera": 1},
                    feasible_interval=[0, 10],
                ),
                *(make_task(n, 2, uses={"camera": 1}) for n in "abcde"),
            ],
        }
    )
    start = plan_of(
        problem, {"long": None, "a": 0, "b": 2, "c": 4, "d": 6, "e": 8}
    )
    better = inserted(problem, start, start_domains(problem))
    assert better.unscheduled == ()
    assert better.starts()["long"] == 0
    assert check_plan(problem, better).ok


def test_a_task_comes_in_beside_a_group_whose_option_moves() -> None:
    """Tests insertion in a problem with a group of alternatives: the
    left-out task takes the camera from the chosen option's task, which
    moves but stays (members are neither inserted nor dropped one by
    one), the plan names the group's choice, and the checker accepts it
    at a lower objective."""
    problem = problem_from(
        {
            "horizon": 8,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task("hf", 4, delay_cost=1, uses={"camera": 1}),
                make_task("lf", 4, delay_cost=1, uses={"camera": 1}),
                make_task(
                    "b",
                    4,
                    delay_cost=5,
                    schedule_cost=5,
                    uses={"camera": 1},
                    feasible_interval=[0, 4],
                ),
            ],
            "alternatives": [
                {"id": "img", "schedule_cost": 1, "options": [["hf"], ["lf"]]}
            ],
        }
    )
    start = plan_of(problem, {"hf": 0, "lf": None, "b": None})
    assert start.unscheduled == ("b",)
    better = inserted(problem, start, start_domains(problem))
    assert better.activities == (Activity("b", 0, 4), Activity("hf", 4, 8))
    assert better.unscheduled == ()
    assert better.chosen == {"img": 0}
    assert check_plan(problem, better).ok
    assert better.objective is not None and start.objective is not None
    assert better.objective.total < start.objective.total


@settings(COMMON, max_examples=300)
@given(
    doc=mission_docs(max_tasks=5, max_horizon=8),
    drop=st.sets(st.integers(0, 4)),
)
def test_insertion_on_mission_days_gives_valid_better_plans(
    doc: dict, drop: set[int]
) -> None:
    """Tests, on drawn days with a group of alternatives, a binary window,
    capacity steps and an external rate, that insertion from any valid
    plan at earliest starts returns that plan or a valid one of lower
    objective."""
    problem = decode_doc(doc)
    start = at_earliest_but(problem, drop)
    if start is None or start.objective is None:
        return
    domains = start_domains(problem)
    better = inserted(problem, start, domains)
    if better is start:
        return
    report = check_plan(problem, better)
    assert report.ok, (doc, better)
    assert better.objective == report.objective
    assert better.objective is not None
    assert better.objective.total < start.objective.total


def test_a_task_is_inserted_where_a_pass_leaves_room() -> None:
    """Tests insertion on a camera that is only available in two passes:
    the left-out task, which must start in the first pass, goes in once
    the one holding that pass moves to the second."""
    problem = problem_from(
        {
            "horizon": 30,
            "resources": {
                "binary": {"camera": {"available": [[0, 10], [20, 30]]}},
                "multiple": {},
                "consumable": {},
            },
            "tasks": [
                make_task("a", 6, delay_cost=1, uses={"camera": 1}),
                make_task(
                    "b",
                    6,
                    delay_cost=1,
                    schedule_cost=5,
                    uses={"camera": 1},
                    feasible_interval=[0, 10],
                ),
            ],
        }
    )
    start = plan_of(problem, {"a": 0, "b": None})
    assert start.unscheduled == ("b",)
    better = inserted(problem, start, start_domains(problem))
    assert better.unscheduled == ()
    assert better.activities == (Activity("b", 0, 6), Activity("a", 20, 26))
    assert check_plan(problem, better).ok
    assert better.objective is not None and start.objective is not None
    assert better.objective.total < start.objective.total


def test_a_placed_tight_partner_is_lifted_to_make_room() -> None:
    """Tests that a left-out task whose only start (tight after a placed
    task) is taken by a task that cannot move gets in by moving that
    partner: ``q`` must start when ``p`` ends, at 2, where the required
    ``b`` holds the camera until 4; ``p`` goes to 4 and ``q`` to 6.
    Without lifting ``p`` no move places ``q`` (``b`` has no other
    start)."""
    camera = {"camera": 1}
    problem = problem_from(
        {
            "horizon": 20,
            "resources": {"binary": ["camera"]},
            "tasks": [
                make_task("p", 2, uses=camera),
                make_task(
                    "b",
                    2,
                    schedule_cost=0,
                    feasible_interval=[2, 4],
                    uses=camera,
                ),
                make_task("q", 2, schedule_cost=3, uses=camera),
            ],
            "precedences": [
                {
                    "before": "p",
                    "after": "q",
                    "kind": "tight",
                    "scope": "at_least_first",
                }
            ],
        }
    )
    start = plan_of(problem, {"p": 0, "b": 2, "q": None})
    assert check_plan(problem, start).ok and start.unscheduled == ("q",)
    found = inserted(problem, start, start_domains(problem))
    assert found.starts() == {"b": 2, "p": 4, "q": 6}
    assert check_plan(problem, found).ok
    assert found.objective is not None and start.objective is not None
    assert found.objective.total < start.objective.total
