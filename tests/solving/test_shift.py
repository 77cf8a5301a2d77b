"""The shift windows of :class:`~fsw_scheduler.solving.polishing.
Polishing`: every kept task moved a few units at once by CBC."""

from __future__ import annotations

import functools
import time

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import checked_starts
from fsw_scheduler.analysis.polish import polished
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.polishing import Polishing

from ..factories import make_doc, make_task, problem_from

RUN = functools.partial(solve_ilp, solver="cbc", threads=1, seed=0)


def _chain() -> tuple:
    """Three tasks in a tight chain (each starts when the one before
    ends), a fourth on the camera, and a plan with the chain 4 units
    late: no single task may move alone."""
    doc = make_doc(
        [
            make_task("x", 3, uses={"cam": 1}),
            make_task("y", 3),
            make_task("z", 3),
            make_task("w", 2, uses={"cam": 1}),
        ],
        horizon=30,
        resources={"binary": ["cam"]},
        precedences=[
            {"before": "x", "after": "y", "kind": "tight", "offset": 0},
            {"before": "y", "after": "z", "kind": "tight", "offset": 0},
        ],
    )
    problem = problem_from(doc)
    plan = checked_starts(problem, {"x": 4, "y": 7, "z": 10, "w": 0})
    assert plan is not None
    return problem, start_domains(problem), plan


def test_a_chain_the_polish_cannot_move_is_shifted_together() -> None:
    """Tests that a tight chain started late, which no one- or two-task
    move can bring earlier, is moved earlier as a whole by the shift
    windows (the task in its way moved later where that pays), the plan
    checked and its saving said."""
    problem, domains, plan = _chain()
    assert polished(problem, plan, domains).starts() == plan.starts()
    polish = Polishing(problem, domains, time.perf_counter() + 30, None)
    shifted = polish.shifted(plan, RUN, time.perf_counter() + 30)
    # The camera goes to the chain first: w waits 3, the chain gains 12.
    assert shifted.starts() == {"x": 0, "y": 3, "z": 6, "w": 3}
    assert shifted.status is SolveStatus.FEASIBLE
    assert check_plan(problem, shifted).ok
    assert plan.objective is not None and shifted.objective is not None
    saved = plan.objective.total - shifted.objective.total
    assert saved == 9
    assert polish.said() == ("; tasks shifted together: 9 delay units saved")


def test_the_shift_keeps_a_plan_at_its_bound_and_respects_the_clock() -> None:
    """Tests that a plan meeting the bound is returned as it is, and that
    with less time left than CBC needs no window is solved."""
    problem, domains, plan = _chain()
    assert plan.objective is not None
    at_bound = Polishing(
        problem, domains, time.perf_counter() + 30, plan.objective.total
    )
    assert at_bound.shifted(plan, RUN, time.perf_counter() + 30) is plan
    late = Polishing(problem, domains, time.perf_counter() + 30, None)
    assert late.shifted(plan, RUN, time.perf_counter() + 0.1) is plan
    assert late.said() == ""


def test_left_out_tasks_stay_out_of_the_shift_windows() -> None:
    """Tests that a task the plan leaves out is not added by the shift
    (the windows only move what is kept: the kept set is the search's)."""
    problem, domains, _ = _chain()
    plan = checked_starts(problem, {"x": 4, "y": 7, "z": 10})
    assert plan is not None and "w" in plan.unscheduled
    polish = Polishing(problem, domains, time.perf_counter() + 30, None)
    shifted = polish.shifted(plan, RUN, time.perf_counter() + 30)
    assert "w" in shifted.unscheduled
    assert shifted.starts() == {"x": 0, "y": 3, "z": 6}
    assert check_plan(problem, shifted).ok
