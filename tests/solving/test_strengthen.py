"""Tests of the clique rows of multiple resources."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pulp
import pytest
from hypothesis import given, settings

from fsw_scheduler.solving.ilp import constraints
from fsw_scheduler.solving.ilp.cbc import cbc_path
from fsw_scheduler.solving.ilp.model import BuiltModel
from fsw_scheduler.solving.ilp.strengthen import (
    clique_sets,
    pairwise_prefix,
    strengthening_rows,
)

from ..factories import make_doc, make_task, problem_from
from ..problems import (
    COMMON,
    candidates,
    decode_doc,
    is_feasible,
    mission_docs,
    problem_docs,
)

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem
    from fsw_scheduler.solving.ilp.program import Terms


def _rows(built: BuiltModel) -> list[tuple[str, Terms, float]]:
    """Every strengthening row of ``built``'s multiple resources."""
    problem = built.problem
    rows = []
    for name in problem.resources.multiple:
        users = [
            (task, task.uses[name])
            for task in problem.tasks
            if task.uses.get(name, 0) and built.vars.placeable(task.id)
        ]
        capacity = problem.resources.capacity_profile(
            name, problem.start, problem.horizon
        )
        rows += [
            (name, terms, bound)
            for terms, bound in strengthening_rows(
                built.vars, users, capacity, problem.start
            )
        ]
    return rows


def _lp_bound(problem: Problem) -> float:
    """The optimum of the time-indexed model's LP relaxation."""
    lp, columns = BuiltModel(problem).program.to_pulp()
    for column in columns:
        column.cat = pulp.LpContinuous
    # CBC in its own process: HiGHS in this one (highspy) left state that
    # made later solves of other tests in the process say "feasible".
    lp.solve(pulp.COIN_CMD(msg=False, path=cbc_path()))
    assert pulp.LpStatus[lp.status] == "Optimal"
    return float(pulp.value(lp.objective))


def test_pairwise_prefix_of_a_knapsack() -> None:
    """Tests that the pairwise prefix is the largest set of the largest
    users whose two smallest conflict, and that it is left out where the
    knapsack row implies it or no two conflict."""
    assert pairwise_prefix([6, 5, 4, 3], 10) == 2  # 6 + 5 > 10, 5 + 4 not
    assert pairwise_prefix([8, 7, 5, 4], 10) == 3  # 7 + 5 > 10
    assert pairwise_prefix([6, 6, 6], 10) == 3
    assert pairwise_prefix([12, 3], 10) == 2  # 12 never runs: still valid
    assert pairwise_prefix([10, 10], 10) == 0  # the knapsack says it
    assert pairwise_prefix([5, 5, 5], 10) == 0  # no two conflict
    assert pairwise_prefix([7], 10) == 0


def test_clique_sets_of_a_threshold_graph() -> None:
    """Tests that each user at most half the capacity gets the clique of
    the larger users it cannot run beside."""
    # 5 with 8 and 7 (> 5); 4 with 8 and 7 (> 6); 3 with 8 (> 7); 2: none.
    assert clique_sets([8, 7, 5, 4, 3, 2], 10) == [(2, 2), (3, 2), (4, 1)]
    assert clique_sets([5, 5], 10) == []


def test_clique_inside_the_pairwise_row_is_left_out() -> None:
    """Tests that a clique the pairwise prefix holds is not written twice,
    and one it does not hold is."""
    # 8 + 5 > 10 and 8 + 3 > 10, 5 + 3 fit: the prefix {8, 5} <= 1 (the
    # clique of 5) and the clique {8, 3} <= 1.
    doc = make_doc(
        [
            make_task(name, 1, schedule_cost=5, uses={"m": amount})
            for name, amount in (("a", 8), ("b", 5), ("c", 3))
        ],
        horizon=1,
        resources={"multiple": {"m": 10}},
    )
    built = BuiltModel(problem_from(doc))
    found = sorted(
        (sorted(built.program.column_name(c) for c in terms), bound)
        for _, terms, bound in _rows(built)
    )
    steps = {
        name: built.program.column_name(built.vars.scheduled(name))
        for name in "abc"
    }
    assert found == sorted(
        [
            (sorted([steps["a"], steps["b"]]), 1.0),
            (sorted([steps["a"], steps["c"]]), 1.0),
        ]
    )


@pytest.mark.parametrize(
    ("amounts", "share"), [((6, 6, 6), 2 / 3), ((8, 5, 3), 0.75)]
)
def test_rows_raise_the_lp_bound(
    amounts: tuple[int, ...], share: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that the rows raise the LP bound where the knapsack row lets
    users that cannot run together each run a fraction."""
    doc = make_doc(
        [
            make_task(f"t{idx}", 2, schedule_cost=5, uses={"m": amount})
            for idx, amount in enumerate(amounts)
        ],
        horizon=2,
        resources={"multiple": {"m": 10}},
    )
    problem = problem_from(doc)
    stronger = _lp_bound(problem)
    monkeypatch.setattr(constraints, "strengthening_rows", lambda *_: iter(()))
    weaker = _lp_bound(problem)
    # Every start is at 0 (no delay): the bound is the cost of the tasks
    # left out. (6, 6, 6): the knapsack lets 5/3 of the 3 run, the row
    # one (4/3 left out against 2). (8, 5, 3): 5 and 3 run
    # with a quarter of 8 under the knapsack; the rows {8, 5} <= 1 and
    # {8, 3} <= 1 leave one whole task out.
    assert stronger > 0
    assert weaker == pytest.approx(share * stronger)


def test_rows_read_the_capacity_of_each_unit() -> None:
    """Tests that a capacity step changes the rows: users of four each
    conflict where the capacity is 6, not where it is 10."""
    doc = make_doc(
        [make_task(name, 1, schedule_cost=5, uses={"m": 4}) for name in "abc"],
        horizon=4,
        resources={"multiple": {"m": {"steps": [[0, 10], [2, 6]]}}},
    )
    built = BuiltModel(problem_from(doc))
    bounds = {}
    for _, terms, bound in _rows(built):
        # The unit a row is written for: the column with coefficient +1
        # of the first task (its step at that unit).
        steps = [built.vars.step("a", t) for t in range(4)]
        (time,) = {
            t
            for t, step in enumerate(steps)
            if step is not None and terms.get(step) == 1.0
        }
        bounds[time] = bound
    assert bounds == {2: 1.0, 3: 1.0}


def _feasible(problem: Problem) -> list[dict[str, int | None]]:
    """Every assignment the exhaustive search accepts (small problems)."""
    return [s for s in candidates(problem) if is_feasible(problem, s)]


def _holds_for_every_plan(problem: Problem) -> None:
    """Assert that no strengthening row cuts off a feasible assignment."""
    built = BuiltModel(problem)
    rows = _rows(built)
    for starts in _feasible(problem):
        placed = {k: v for k, v in starts.items() if v is not None}
        values = built.vars.initial(placed, built.program.num_columns)
        # The columns carry the plan (its starts lie in the domains).
        assert all(
            built.vars.start_of(k, values) == v for k, v in starts.items()
        )
        for name, terms, bound in rows:
            used = sum(coef * values[col] for col, coef in terms.items())
            assert used <= bound + 1e-9, (name, starts, terms, bound)


@settings(COMMON, max_examples=80)
@given(doc=problem_docs(max_tasks=4, max_horizon=8))
def test_rows_keep_every_feasible_plan(doc: dict) -> None:
    """Tests that the rows hold for every assignment the exhaustive search
    accepts, on generated problems with multiple resources."""
    _holds_for_every_plan(decode_doc(doc))


@settings(COMMON, max_examples=40)
@given(doc=mission_docs(max_tasks=4, max_horizon=8))
def test_rows_keep_every_feasible_plan_under_capacity_steps(
    doc: dict,
) -> None:
    """Tests that the rows hold for every feasible assignment of generated
    problems whose multiple resource has capacity steps."""
    _holds_for_every_plan(decode_doc(doc))
