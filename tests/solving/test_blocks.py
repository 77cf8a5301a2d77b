"""Binary windows and capacity steps in the disjunctive model, held by
pinned blocks (:mod:`fsw_scheduler.solving.ilp.disjunctive.blocks`)."""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.errors import SolverError
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.ilp.disjunctive import blocks
from fsw_scheduler.solving.ilp.disjunctive.rule import pick

from ..factories import make_doc, make_task, problem_from

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem, Task

#: A camera with a gap and a power profile with a low step and a zero one.
RESOURCES = {
    "binary": {"camera": {"available": [[2, 10], [13, 30]]}},
    "multiple": {"power": {"steps": [[0, 10], [8, 4], [12, 10], [20, 0]]}},
}


def _blocks(problem: Problem, names: list[str]) -> list[Task]:
    """The block tasks :func:`blocks.blocked` adds for ``names``."""
    wide = blocks.blocked(problem, start_domains(problem), names)
    assert wide is not None
    return [t for t in wide[0].tasks if t.id.startswith(blocks.PREFIX)]


def test_blocks_are_the_stretches_under_the_peak() -> None:
    """Tests each block: the camera outside its windows (the horizon's
    end included), the power's shortfall from its peak of 10 per
    stretch, pinned and mandatory, without costs."""
    problem = problem_from(
        make_doc(
            [make_task("a", 2, uses={"camera": 1, "power": 3})],
            horizon=30,
            resources=RESOURCES,
        )
    )
    found = _blocks(problem, ["camera", "power"])
    assert [
        (t.id, t.fixed_start, t.length, t.uses, t.schedule_cost, t.delay_cost)
        for t in found
    ] == [
        ("~camera@0", 0, 2, {"camera": 1.0}, 0, 0),
        ("~camera@10", 10, 3, {"camera": 1.0}, 0, 0),
        ("~power@8", 8, 4, {"power": 6.0}, 0, 0),
        ("~power@20", 20, 10, {"power": 10.0}, 0, 0),
    ]
    wide = blocks.blocked(problem, start_domains(problem), ["power"])
    assert wide is not None
    model, domains = wide
    assert model.resources.multiple == {"power": 10.0}
    # Only the resources named are blocked: the camera keeps its windows.
    assert model.resources.binary == problem.resources.binary
    assert {t.id for t in model.tasks} == {"a", "~power@8", "~power@20"}
    assert domains["~power@8"].earliest == domains["~power@8"].latest == 8


def test_a_resource_never_available_is_blocked_whole() -> None:
    """Tests a camera with no window: one block over the horizon, and
    its user left out by either model."""
    doc = make_doc(
        [make_task("a", 2, uses={"camera": 1})],
        horizon=10,
        resources={"binary": {"camera": {"available": []}}},
    )
    problem = problem_from(doc)
    found = _blocks(problem, ["camera"])
    assert [(t.fixed_start, t.length) for t in found] == [(0, 10)]
    for formulation in ("disjunctive", "time-indexed"):
        plan = solve_ilp(problem, formulation=formulation)
        assert plan.status is SolveStatus.OPTIMAL
        assert plan.unscheduled == ("a",)


def test_what_stays_with_the_time_indexed_model() -> None:
    """Tests the limits: a consumable's external rate cannot be blocked
    (asking for the disjunctive model is an error), nor more stretches
    than MAX_BLOCKS."""
    drained = problem_from(
        make_doc(
            [make_task("a", 2, uses={"camera": 1})],
            horizon=10,
            resources={
                "binary": ["camera"],
                "consumable": {"bat": {"initial": 9, "external": [[2, -1]]}},
            },
        )
    )
    assert pick(drained, start_domains(drained)) == "time-indexed"
    with pytest.raises(SolverError, match="time-indexed"):
        solve_ilp(drained, formulation="disjunctive")
    many = [[k, k + 1] for k in range(0, 2 * blocks.MAX_BLOCKS + 4, 2)]
    passes = problem_from(
        make_doc(
            [make_task(f"t{k}", 1, uses={"camera": 1}) for k in range(3)],
            horizon=2 * blocks.MAX_BLOCKS + 4,
            resources={"binary": {"camera": {"available": many}}},
        )
    )
    assert blocks.blocked(passes, start_domains(passes), ["camera"]) is None
    assert pick(passes, start_domains(passes)) == "time-indexed"


@st.composite
def _days(draw: Any) -> dict[str, Any]:
    """Small days on a camera with windows and a power profile, from a
    start of 0 to 5."""
    horizon = draw(st.integers(12, 30))
    begin = draw(st.integers(0, 5))  # the problem's start
    cuts = sorted(draw(st.sets(st.integers(1, horizon - 1), max_size=4)))
    edges = [begin + t for t in (0, *cuts, horizon)]
    windows = [
        [a, b]
        for k, (a, b) in enumerate(itertools.pairwise(edges))
        if k % 2 == 0
    ]
    levels = draw(st.lists(st.integers(0, 10), min_size=1, max_size=4))
    at = sorted(
        draw(st.sets(st.integers(begin + 1, begin + horizon - 1), max_size=3))
    )
    steps = [[begin, levels[0]]] + [
        [t, levels[k % len(levels)]] for k, t in enumerate(at, 1)
    ]
    tasks = []
    for k in range(draw(st.integers(2, 6))):
        uses: dict[str, int] = {}
        if draw(st.booleans()):
            uses["camera"] = 1
        if draw(st.booleans()):
            uses["power"] = draw(st.integers(1, 8))
        tasks.append(
            make_task(
                f"t{k}",
                draw(st.integers(1, 6)),
                delay_cost=draw(st.integers(1, 5)),
                schedule_cost=draw(st.integers(0, 5)),
                uses=uses,
            )
        )
    return make_doc(
        tasks,
        horizon=horizon,
        start=begin,
        resources={
            "binary": {"camera": {"available": windows}},
            "multiple": {"power": {"steps": steps}},
        },
    )


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(_days())
def test_both_models_agree_on_windows_and_steps(doc: dict[str, Any]) -> None:
    """Tests, on random days, that the disjunctive model with blocks and
    the time-indexed model (a row per unit with its capacity) find the
    same status and optimum, and that the checker accepts the plan."""
    problem = problem_from(doc)
    plans = {
        formulation: solve_ilp(problem, formulation=formulation)
        for formulation in ("disjunctive", "time-indexed")
    }
    blocked, indexed = plans["disjunctive"], plans["time-indexed"]
    assert blocked.status is indexed.status
    if indexed.status is SolveStatus.OPTIMAL:
        assert blocked.objective is not None and indexed.objective is not None
        assert blocked.objective.total == indexed.objective.total
        assert check_plan(problem, blocked).ok
        assert not any(a.task.startswith("~") for a in blocked.activities)
