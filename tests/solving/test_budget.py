"""Tests of the time budgets of a solve (budget.py)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.budget import BUDGET
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.ilp.cbc import (
    MIN_CBC_S,
    STOP_MARGIN_MIN_S,
    STOP_MARGIN_S,
    stop_margin,
)
from fsw_scheduler.solving.solve import solve

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


def _small_binary_problem():
    return problem_from(
        make_doc(
            [
                make_task(
                    f"c{idx}",
                    2 + idx % 3,
                    delay_cost=1 + idx % 5,
                    uses={"cam": 1},
                )
                for idx in range(6)
            ],
            horizon=30,
            resources={"binary": ["cam"]},
        )
    )


def test_the_stop_margin_grows_with_the_model() -> None:
    """Tests that a small model is stopped just before its share ends and
    a large one with the whole margin."""
    assert stop_margin(9_000) == STOP_MARGIN_MIN_S
    assert STOP_MARGIN_MIN_S < stop_margin(50_000) < STOP_MARGIN_S
    assert stop_margin(1_000_000) == STOP_MARGIN_S
    # The solve reads and checks CBC's answer within its limit: a longer
    # limit keeps the whole margin whatever the model.
    assert stop_margin(9_000, 0.3) == STOP_MARGIN_MIN_S
    assert stop_margin(9_000, 10.0) == STOP_MARGIN_S


def test_cbc_proves_a_small_model_under_a_short_limit() -> None:
    """Tests that a limit below the large-model margin still runs CBC on
    a small model: six users of one camera, one order proved best, within
    a quarter of a second (CBC once never started under 0.35 s)."""
    problem = _small_binary_problem()
    plan = solve_ilp(problem, time_limit=0.25)
    assert plan.stats is not None
    assert plan.status is SolveStatus.OPTIMAL, plan.stats.solver_status
    whole = solve(problem, time_limit=0.25)
    assert whole.status is SolveStatus.OPTIMAL, whole.stats
    assert whole.objective == plan.objective


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
