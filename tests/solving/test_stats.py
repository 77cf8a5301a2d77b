"""Tests of what a solve's answer says of itself (solving.stats)."""

from __future__ import annotations

import time

from fsw_scheduler.model.plan import (
    Objective,
    Plan,
    SolverStats,
    SolveStatus,
)
from fsw_scheduler.solving.stats import with_call_stats, with_gap


def _plan(total: int, bound: float | None) -> Plan:
    return Plan(
        SolveStatus.FEASIBLE,
        Objective(unscheduled_cost=0, delay_cost=total, total=total),
        (),
        (),
        stats=SolverStats(solver="cbc", bound=bound),
    )


def test_the_highest_bound_that_holds_is_reported() -> None:
    """Tests that the answer's bound is the highest of the solver's, the
    kept-set relaxation's and the disjunctive relaxation's that is not
    above the plan (one above it bounds nothing), and that the gap is
    taken from it."""
    began = time.perf_counter()
    plan = with_call_stats(_plan(100, 80.0), began, 5.0, 90.0, 95.0)
    assert plan.stats is not None
    assert plan.stats.bound == 95.0
    assert plan.stats.time_limit_s == 5.0
    assert 0.0 <= plan.stats.wall_s < 60.0
    gapped = with_gap(plan)
    assert gapped.stats is not None and gapped.stats.gap == 5.0
    # A bound above the plan is dropped, the solver's as well.
    plan = with_call_stats(_plan(100, 120.0), began, None, 101.0, None)
    assert plan.stats is not None and plan.stats.bound is None
    plan = with_call_stats(_plan(100, None), began, None, 70.0, 60.0)
    assert plan.stats is not None and plan.stats.bound == 70.0
