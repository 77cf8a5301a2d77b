"""Tests of the time budgets of a solve (budget.py)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.budget import BUDGET
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.ilp.cbc import MIN_CBC_S, STOP_MARGIN_S

from ..factories import make_doc, make_task, problem_from
from ..problems import COMMON


def test_a_part_share_is_enough_to_start_cbc() -> None:
    """Tests that the least share of a part lets CBC start and prove a
    small model that needs it."""
    assert BUDGET.min_part_s > STOP_MARGIN_S + MIN_CBC_S
    problem = problem_from(
        make_doc(
            [
                make_task(f"c{idx}", 3, delay_cost=1 + idx, uses={"cam": 1})
                for idx in range(4)
            ],
            horizon=30,
            resources={"binary": ["cam"]},
        )
    )
    plan = solve_ilp(problem, time_limit=BUDGET.min_part_s)
    assert plan.stats is not None
    assert plan.status is SolveStatus.OPTIMAL, plan.stats.solver_status


@settings(COMMON, max_examples=200)
@given(
    left=st.floats(0.0, 100.0),
    weights=st.lists(st.integers(1, 10_000), min_size=1, max_size=40),
)
def test_part_share_floor_and_sum(left: float, weights: list[int]) -> None:
    """Tests that a part's share is at least its size's share and the
    floor (or an equal split when the floor does not fit), and never more
    than what is left."""
    share = BUDGET.part_share(left, weights)
    assert 0.0 <= share <= left + 1e-9
    assert share >= left * weights[0] / sum(weights) - 1e-9
    if left >= BUDGET.min_part_s * len(weights):
        assert share >= BUDGET.min_part_s
    else:
        assert share >= left / len(weights) - 1e-9
