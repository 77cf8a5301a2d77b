"""Tests of candidate starts: the time-indexed model over a subset of each
task's starts (the neighbourhood search's sub-models)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.check import check_plan, format_report
from fsw_scheduler.analysis.domains import Domain, start_domains
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.ilp import cbc
from fsw_scheduler.solving.ilp.model import BuiltModel, solve_ilp
from fsw_scheduler.solving.ilp.variables import with_starts
from fsw_scheduler.solving.improve import (
    DENSE_STARTS,
    GRID_STARTS,
    candidate_starts,
)

from ..factories import make_doc, make_task, problem_from
from ..problems import (
    COMMON,
    candidates,
    decode_doc,
    is_feasible,
    objective_of,
    problem_docs,
    show,
)


def _waits_for_a() -> dict:
    """``b`` must wait for ``a`` on the camera; ``a`` is pinned at 0."""
    return make_doc(
        [
            make_task("a", 7, fixed_start=0, uses={"camera": 1}),
            make_task("b", 5, delay_cost=2, uses={"camera": 1}),
        ],
        horizon=100,
        resources={"binary": ["camera"]},
    )


def test_a_task_starts_only_at_its_candidates() -> None:
    """Tests that ``b``, which could start at 7 once ``a`` ends, starts at
    the first candidate after it, with the delay counted to that start."""
    problem = problem_from(_waits_for_a())
    domains = start_domains(problem)
    last = domains["b"].latest
    plan = solve_ilp(
        problem,
        domains=domains,
        formulation="time-indexed",
        candidates={"b": [0, 3, 10, 40, last]},
    )
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.starts() == {"a": 0, "b": 10}
    assert plan.objective is not None
    assert plan.objective.delay_cost == 2 * 10
    assert check_plan(problem, plan).ok


def test_the_objective_counts_each_candidate_step_by_its_width() -> None:
    """Tests that the program's objective at a start is the plan's, for
    every candidate start (the widths between candidates)."""
    problem = problem_from(_waits_for_a())
    domains = start_domains(problem)
    starts = [0, 3, 10, 40, domains["b"].latest]
    built = BuiltModel(problem, domains, candidates={"b": starts})
    program = built.program
    for start in starts[1:]:
        values = built.vars.initial({"a": 0, "b": start}, program.num_columns)
        cost = program.constant + sum(
            c * v for c, v in zip(program.cost, values, strict=True)
        )
        plan = built.decode(SolveStatus.FEASIBLE, values)
        assert plan.starts()["b"] == start
        assert plan.objective is not None
        assert cost == pytest.approx(plan.objective.total)


def test_candidates_must_hold_the_domain_ends() -> None:
    """Tests that candidate starts missing an end of the domain are
    refused (the last step is the task's "scheduled" column)."""
    problem = problem_from(_waits_for_a())
    with pytest.raises(ValueError, match="domain's ends"):
        BuiltModel(problem, candidates={"b": [0, 10]})


def test_repeated_rows_are_written_once() -> None:
    """Tests that the rows of the units between two candidates, the same
    as the unit's before, are written once."""
    problem = problem_from(_waits_for_a())
    domains = start_domains(problem)
    dense = BuiltModel(problem, domains)
    sparse = BuiltModel(
        problem, domains, candidates={"b": [0, 50, domains["b"].latest]}
    )
    assert sparse.num_variables == 1 + 3
    assert sparse.num_constraints < dense.num_constraints / 10
    rows = [
        (tuple(sorted(terms.items())), sense, rhs)
        for terms, sense, rhs in sparse.program.rows
    ]
    assert len(rows) == len(set(rows))


@settings(COMMON, max_examples=120)
@given(doc=problem_docs(max_tasks=4, max_horizon=8), data=st.data())
def test_candidate_model_finds_the_best_plan_with_those_starts(
    doc: dict, data: st.DataObject
) -> None:
    """Tests that, over random candidate starts, CBC's optimum is the best
    plan exhaustive search finds when each task starts at one of its
    candidates (or is left out), and passes the checker."""
    problem = decode_doc(doc)
    domains = start_domains(problem)
    allowed: dict[str, list[int]] = {}
    for task in problem.tasks:
        domain = domains[task.id]
        if domain.empty:
            continue
        inner = range(domain.earliest + 1, domain.latest)
        chosen = data.draw(
            st.sets(st.sampled_from(inner)) if inner else st.just(set()),
            label=task.id,
        )
        allowed[task.id] = sorted({domain.earliest, domain.latest, *chosen})
    best = None
    for starts in candidates(problem):
        if any(
            start is not None and start not in allowed.get(name, ())
            for name, start in starts.items()
        ):
            continue
        if is_feasible(problem, starts):
            total = objective_of(problem, starts).total
            best = total if best is None else min(best, total)
    plan = solve_ilp(
        problem,
        domains=domains,
        formulation="time-indexed",
        candidates=allowed,
    )
    if best is None:
        assert plan.status is SolveStatus.INFEASIBLE, show(doc, plan)
        return
    assert plan.status is SolveStatus.OPTIMAL, show(doc, plan)
    assert plan.objective is not None
    assert plan.objective.total == best, show(doc, plan)
    report = check_plan(problem, plan)
    assert report.ok, format_report(report)
    for name, start in plan.starts().items():
        assert start in allowed[name]


def test_candidate_starts_of_a_neighbourhood() -> None:
    """Tests what a wide free task keeps: its domain's ends, its start,
    the ends of the placed tasks, the starts its precedences ask for and
    a grid; a narrow one and a pinned one get none."""
    doc = make_doc(
        [
            make_task("a", 7),
            make_task("b", 5),
            make_task("c", 3, fixed_start=100),
            make_task("d", 4, fixed_start=200),
        ],
        horizon=1000,
        precedences=[
            dict(before="a", after="b", kind="lax", scope="both", offset=2)
        ],
    )
    problem = problem_from(doc)
    plan = solve_ilp(problem, formulation="time-indexed").replace(
        status=SolveStatus.FEASIBLE
    )
    starts = plan.starts()
    free = {
        "b": start_domains(problem)["b"],
        "d": type(start_domains(problem)["d"])(0, DENSE_STARTS - 1),
        "a": type(start_domains(problem)["a"])(starts["a"], starts["a"]),
    }
    found = candidate_starts(problem, plan, free)
    assert set(found) == {"b"}  # d's domain is narrow, a is pinned
    points = found["b"]
    low, high = free["b"].earliest, free["b"].latest
    assert points[0] == low and points[-1] == high
    assert points == sorted(set(points))
    assert starts["b"] in points
    assert starts["a"] + 7 + 2 in points  # after a, by the precedence
    assert all(starts[n] + problem.task(n).length in points for n in "cd")
    assert len(points) <= GRID_STARTS + 2 + len(problem.tasks) + 4


def test_a_warm_start_between_candidates_joins_them() -> None:
    """Tests that a warm start the candidates miss becomes one (with a
    start outside the domain left out): the time-indexed model would put
    the task at the candidate before, which breaks a row, and CBC would
    search without the plan it was given. Seen where a disjunctive run
    hands its better plan to the time-indexed model over the incumbent's
    candidates (``tools/fuzz --large`` seed 1218)."""
    assert with_starts(
        {"b": [0, 10, 40], "c": [2, 9]},
        {"a": 3, "b": 7, "c": 30, "d": None},
        {"b": Domain(0, 40), "c": Domain(2, 9)},
    ) == {"b": [0, 7, 10, 40], "c": [2, 9]}
    problem = problem_from(_waits_for_a())
    domains = start_domains(problem)
    last = domains["b"].latest
    built = BuiltModel(problem, domains, candidates={"b": [0, 10, last]})
    values = built.vars.initial({"a": 0, "b": 7}, built.program.num_columns)
    # Without the start among the candidates the model cannot hold it:
    # the values given to CBC are another plan, or none.
    assert built.decode(SolveStatus.FEASIBLE, values).starts().get("b") != 7


def test_a_warm_start_between_candidates_is_taken_as_given(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Tests a real CBC run from a warm start between the candidates: no
    warning that CBC refused it, and an answer at least as good."""
    problem = problem_from(_waits_for_a())
    domains = start_domains(problem)
    last = domains["b"].latest
    with caplog.at_level("WARNING", logger="fsw_scheduler.solver"):
        plan = solve_ilp(
            problem,
            domains=domains,
            formulation="time-indexed",
            warm={"a": 0, "b": 7},
            candidates={"b": [0, 10, 40, last]},
        )
    assert cbc.START_REFUSED not in caplog.text
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.starts() == {"a": 0, "b": 7}
    assert check_plan(problem, plan).ok
