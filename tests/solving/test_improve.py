"""Tests of the neighbourhood search's windows (improve.py)."""

from __future__ import annotations

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.solving import improve

from ..factories import make_doc, make_task, problem_from
from ..problems import plan_of


def _queue() -> tuple:
    """Three camera tasks of 5 back to back from 0, each able to start at
    0: ``b`` waits 5 units at delay cost 3, ``c`` 10 at delay cost 1."""
    problem = problem_from(
        make_doc(
            [
                make_task("a", 5, uses={"cam": 1}, delay_cost=1),
                make_task("b", 5, uses={"cam": 1}, delay_cost=3),
                make_task("c", 5, uses={"cam": 1}, delay_cost=1),
            ],
            horizon=40,
            resources={"binary": ["cam"]},
        )
    )
    plan = plan_of(problem, {"a": 0, "b": 5, "c": 10})
    assert check_plan(problem, plan).ok
    return problem, plan, start_domains(problem)


def test_delayed_windows_end_where_the_costliest_late_tasks_end() -> None:
    """Tests that the search's windows about late tasks come first for
    the task whose wait costs most, end where it ends, start no sooner
    than its earliest start, and name it."""
    problem, plan, domains = _queue()
    windows = improve._windows_delayed(problem, plan, domains, size=6)
    # b waits 5 x 3 = 15, c waits 10 x 1 = 10; a does not wait.
    assert [name for _, _, name in windows] == ["b", "c"]
    low, high, _ = windows[0]
    assert high == 10
    assert domains["b"].earliest <= low < high


def test_a_late_task_is_free_in_its_window_with_the_tasks_before_it() -> None:
    """Tests that the neighbourhood of a late task's window frees that
    task, even when the window is full, and the task just before it
    first; the task after the window stays pinned."""
    problem, plan, domains = _queue()
    narrowed = improve._neighbourhood(
        problem, plan, domains, 0, 10, size=2, late="b"
    )
    assert narrowed is not None
    free = {
        name
        for name, domain in narrowed.items()
        if domain.latest > domain.earliest
    }
    assert free == {"a", "b"}
    assert narrowed["c"].earliest == narrowed["c"].latest == 10
