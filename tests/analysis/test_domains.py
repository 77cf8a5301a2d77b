"""Tests of start domains (fsw_scheduler.analysis.domains) with resources
that change over time."""

from __future__ import annotations

from fsw_scheduler.analysis.domains import start_domains

from ..factories import make_doc, make_task, problem_from


def test_windows_and_steps_bound_the_starts() -> None:
    """Tests that a task's domain starts at the first start whose whole
    run is inside a window (and under every capacity step it needs), ends
    at the last such start, and is empty, named, when there is none."""
    problem = problem_from(
        make_doc(
            [
                make_task("down", 3, uses={"antenna": 1}),
                make_task("heavy", 2, uses={"power": 3}),
                make_task("never", 7, uses={"antenna": 1}),
                make_task("free", 2),
            ],
            horizon=30,
            resources={
                "binary": {"antenna": {"available": [[2, 4], [9, 15]]}},
                "multiple": {"power": {"steps": [[0, 1], [6, 4], [20, 2]]}},
            },
        )
    )
    domains = start_domains(problem.replace(tasks=problem.tasks[:2]))
    assert (domains["down"].earliest, domains["down"].latest) == (9, 12)
    assert (domains["heavy"].earliest, domains["heavy"].latest) == (6, 18)
    domains = start_domains(problem)
    never = domains["never"]
    assert never.empty
    assert never.cause == "binary"
    assert "never available for its whole length" in never.detail
    assert (domains["free"].earliest, domains["free"].latest) == (0, 28)
