"""Tests of the energy rows of the kept-set relaxation
(fsw_scheduler.analysis.energetic)."""

from __future__ import annotations

import itertools

from hypothesis import given, settings

from fsw_scheduler.analysis import energetic
from fsw_scheduler.analysis.bounds import kept_set_bound, kept_set_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.energetic import energy_rows

from ..factories import problem_from
from ..problems import (
    COMMON,
    brute_force,
    candidates,
    decode_doc,
    is_feasible,
    plan_of,
    problem_docs,
)


def _camera_day() -> dict:
    """Three camera tasks of 5 units over 10: one must go, the cheapest."""
    return {
        "horizon": 10,
        "resources": {"binary": ["camera"]},
        "tasks": [
            {"id": "a", "length": 5, "delay_cost": 1, "schedule_cost": 3,
             "uses": {"camera": 1}},
            {"id": "b", "length": 5, "delay_cost": 1, "schedule_cost": 2,
             "uses": {"camera": 1}},
            {"id": "c", "length": 5, "delay_cost": 1, "schedule_cost": 1,
             "uses": {"camera": 1}},
        ],
    }  # fmt: skip


def _power_pair(horizon: int, capacity: int, amount: int) -> dict:
    """Two 5-unit users ``a`` (worth 2) and ``b`` (worth 1) of ``amount``
    of a power resource of ``capacity``."""
    return {
        "horizon": horizon,
        "resources": {"multiple": {"power": capacity}},
        "tasks": [
            {"id": name, "length": 5, "delay_cost": 1, "schedule_cost": worth,
             "uses": {"power": amount}}
            for name, worth in (("a", 2), ("b", 1))
        ],
    }  # fmt: skip


def test_an_overloaded_camera_raises_the_bound(monkeypatch) -> None:
    """Tests that three 5-unit camera tasks over 10 units make the bound
    count the cheapest one left out (the relaxation without the rows kept
    all three: a bound of 0), below the optimum; with the camera's
    sequencing (the second task kept waits 5 units) the floor is the
    optimum. The plan leaves out the dearer ``b``, so nothing is proved
    and the relaxed optimum's set is handed on."""
    problem = problem_from(_camera_day())
    domains = start_domains(problem)
    plan = plan_of(problem, {"a": 0, "b": None, "c": 5})
    weight = 1 + 10 * 3
    proof = kept_set_plan(problem, plan, domains)
    assert proof.plan is None
    assert proof.bound == weight * 1
    assert proof.kept == {"a", "b"}
    assert proof.floor == weight * 1 + 5
    best = brute_force(problem)
    assert best is not None and best[0].total == proof.floor
    monkeypatch.setattr(energetic, "MAX_ROWS", 0)
    assert kept_set_plan(problem, plan, domains).bound == 0


def test_users_above_half_a_capacity_are_one_at_a_time() -> None:
    """Tests that users of a multiple resource above half its capacity
    get a row of their own, as on a binary resource: two users of 6 of
    10 whose amounts alone fit the horizon's energy (12 units of 60
    against 100) cannot both run in 6 units."""
    problem = problem_from(_power_pair(horizon=6, capacity=10, amount=6))
    domains = start_domains(problem)
    _, limits = energy_rows(problem, domains, problem.tasks)
    assert limits, "the pair above half the capacity has no row"
    plan = plan_of(problem, {"a": 0, "b": None})
    bound = kept_set_bound(problem, plan, domains).bound
    assert plan.objective is not None
    assert bound == plan.objective.total


def test_users_at_half_a_capacity_may_run_together() -> None:
    """Tests that two users of exactly half a capacity, which run side by
    side, get no row that keeps them apart: their plan together meets
    every row, and the bound leaves nothing out."""
    problem = problem_from(_power_pair(horizon=5, capacity=6, amount=3))
    domains = start_domains(problem)
    assert energy_rows(problem, domains, problem.tasks) == (
        {"a": [], "b": []},
        [],
    )
    plan = plan_of(problem, {"a": 0, "b": 0})
    assert kept_set_plan(problem, plan, domains).plan is not None


def test_rows_are_the_most_overloaded_first_and_at_most_the_cap() -> None:
    """Tests that the rows kept are the most overloaded intervals, at most
    ``max_rows`` of them, and that none is kept where the users fit."""
    problem = problem_from(_camera_day())
    domains = start_domains(problem)
    uses, limits = energy_rows(problem, domains, problem.tasks, max_rows=1)
    assert limits == [10.0]
    assert [uses[t][0] for t in "abc"] == [5.0, 5.0, 5.0]
    roomy = problem_from({**_camera_day(), "horizon": 15})
    assert energy_rows(roomy, start_domains(roomy), roomy.tasks) == (
        {"a": [], "b": [], "c": []},
        [],
    )


def test_many_users_get_a_thinned_grid_of_intervals(monkeypatch) -> None:
    """Tests that a group too large for every pair of ends gets evenly
    thinned starts and ends, its first start and last end among them,
    and still finds the overload: 40 camera runs of 3 units within 90."""
    tasks = [
        {"id": f"t{k:02d}", "length": 3, "delay_cost": 1,
         "schedule_cost": 1, "uses": {"camera": 1},
         "feasible_interval": [k, 50 + k]}
        for k in range(40)
    ]  # fmt: skip
    problem = problem_from(
        {"horizon": 100, "resources": {"binary": ["camera"]}, "tasks": tasks}
    )
    domains = start_domains(problem)
    _, full = energy_rows(problem, domains, problem.tasks, max_rows=10_000)
    # 40 users: 9 starts and 9 ends at most (81 intervals, not 1,600).
    monkeypatch.setattr(energetic, "MAX_PAIRS_WORK", 40 * 81)
    uses, grid = energy_rows(problem, domains, problem.tasks, max_rows=10_000)
    assert 0 < len(grid) <= 81 < len(full)
    last = max(d.latest + 3 for d in domains.values())
    # The widest interval, from the first start to the last end, is kept.
    assert float(last) in grid
    at = grid.index(float(last))
    assert sum(row[at] for row in uses.values()) == 120


def test_thinning_keeps_the_ends_and_spreads_the_rest() -> None:
    """Tests that thinning keeps the first and the last point and at most
    the number asked, spread by rank."""
    points = list(range(0, 100, 3))
    assert energetic._thinned(points, 5) == [0, 24, 48, 72, 99]
    assert energetic._thinned(points, 100) == points
    assert energetic._thinned([4, 7, 9], 2) == [4, 9]


@settings(COMMON, max_examples=300)
@given(doc=problem_docs(max_tasks=4, max_horizon=8))
def test_every_valid_plan_meets_every_row(doc: dict) -> None:
    """Tests that every valid assignment of a small problem (exhaustive)
    keeps each energy row within its limit: the rows cut no plan."""
    problem = decode_doc(doc)
    if problem.has_mission_model:
        return
    domains = start_domains(problem)
    placeable = [t for t in problem.tasks if not domains[t.id].empty]
    uses, limits = energy_rows(problem, domains, placeable, max_rows=1_000)
    if not limits:
        return
    for starts in itertools.islice(candidates(problem), 20_000):
        if not is_feasible(problem, starts):
            continue
        for row, limit in enumerate(limits):
            taken = sum(
                uses[t.id][row] for t in placeable if starts[t.id] is not None
            )
            assert taken <= limit + 1e-9, (doc, starts, row)


def test_a_window_limits_each_row_to_what_it_holds() -> None:
    """Tests a camera available in [0, 2) and [6, 10) only: five 1-unit
    users within [0, 8) would fit its 8 units at the peak, but it holds 4
    there, so the row over [0, 8) binds with that limit; and a power
    resource at 10 down to 4 from unit 4: five 4-unit users of 4 within
    [0, 8) take 80, what it holds there is 56."""
    problem = problem_from(
        {
            "horizon": 10,
            "resources": {
                "binary": {"camera": {"available": [[0, 2], [6, 10]]}},
                "multiple": {"power": {"steps": [[0, 10], [4, 4]]}},
            },
            "tasks": [
                {"id": f"t{k}", "length": 1, "delay_cost": 1,
                 "schedule_cost": 1, "feasible_interval": [0, 8],
                 "uses": {"camera": 1}}
                for k in range(5)
            ] + [
                {"id": f"p{k}", "length": 4, "delay_cost": 1,
                 "schedule_cost": 1, "feasible_interval": [0, 8],
                 "uses": {"power": 4}}
                for k in range(5)
            ],
        }
    )  # fmt: skip
    domains = start_domains(problem)
    uses, limits = energy_rows(problem, domains, list(problem.tasks))
    rows = [
        ({name: uses[name][k] for name in uses if uses[name][k]}, limit)
        for k, limit in enumerate(limits)
    ]
    assert ({f"t{k}": 1.0 for k in range(5)}, 4.0) in rows
    assert ({f"p{k}": 16.0 for k in range(5)}, 56.0) in rows
