"""Tests of the machines' sequencing delay (analysis.sequencing)."""

from __future__ import annotations

import itertools

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.sequencing import Job, machine_delay, machines

from ..factories import problem_from
from ..problems import COMMON

JOBS = st.lists(
    st.tuples(st.integers(0, 15), st.integers(1, 8), st.integers(0, 5)),
    max_size=6,
)


def _least_delay(jobs: list[Job]) -> int:
    """The least ``sum w (s - r)`` over every order of ``jobs``, each
    started as soon as the one before ends (no idle time helps a delay
    that only grows)."""
    best = None
    for order in itertools.permutations(jobs):
        now, cost = None, 0
        for release, length, weight in order:
            start = release if now is None else max(now, release)
            cost += weight * (start - release)
            now = start + length
        best = cost if best is None else min(best, cost)
    return 0 if best is None else best


@settings(COMMON, max_examples=600)
@given(jobs=JOBS)
def test_the_bound_is_never_above_the_least_delay(jobs: list[Job]) -> None:
    """Tests that no order of the jobs on one machine costs less than the
    bound, by enumeration of every order."""
    assert machine_delay(jobs) <= _least_delay(jobs), jobs


@settings(COMMON, max_examples=300)
@given(jobs=JOBS, more=st.tuples(
    st.integers(0, 15), st.integers(1, 8), st.integers(0, 5)
))  # fmt: skip
def test_a_task_more_never_lowers_the_bound(
    jobs: list[Job], more: Job
) -> None:
    """Tests that the bound grows with the set, which the kept-set search
    cuts by (the tasks decided so far bound every set extending them)."""
    assert machine_delay([*jobs, more]) >= machine_delay(jobs)


def test_tasks_released_together_pay_their_best_order() -> None:
    """Tests that released together the bound is the best order's delay
    (Smith's rule): a (length 6, cost 3) first, then b (57, 5), then c
    (49, 4): 5 * 6 + 4 * 63 = 282."""
    jobs = [(0, 57, 5), (0, 6, 3), (0, 49, 4)]
    assert machine_delay(jobs) == 282 == _least_delay(jobs)


def test_tasks_that_never_meet_pay_nothing() -> None:
    """Tests that tasks whose earliest runs do not overlap cost nothing,
    nor does a task alone."""
    assert machine_delay([(0, 5, 3), (5, 2, 9), (20, 1, 1)]) == 0
    assert machine_delay([(4, 5, 3)]) == 0
    assert machine_delay([]) == 0


def test_machines_hold_each_task_once() -> None:
    """Tests that a binary resource's users form a machine, a multiple
    resource's users above half its capacity another, and that a task
    on both is on the first only; a machine of one task is left out."""
    costs = {"delay_cost": 1, "schedule_cost": 1}
    problem = problem_from(
        {
            "horizon": 40,
            "resources": {
                "binary": ["camera", "antenna"],
                "multiple": {"power": 10},
            },
            "tasks": [
                {**costs, "id": "a", "length": 3, "uses": {"camera": 1}},
                {**costs, "id": "b", "length": 3,
                 "uses": {"camera": 1, "power": 6}},
                {**costs, "id": "c", "length": 3, "uses": {"power": 6}},
                {**costs, "id": "d", "length": 3, "uses": {"power": 7}},
                {**costs, "id": "e", "length": 3, "uses": {"power": 5}},
                {**costs, "id": "f", "length": 3, "uses": {"antenna": 1}},
            ],
        }
    )  # fmt: skip
    found = machines(problem, start_domains(problem))
    assert found == [("a", "b"), ("c", "d")]
