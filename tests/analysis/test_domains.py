"""Tests of start domains (fsw_scheduler.analysis.domains) with resources
that change over time."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.domains import start_domains

from ..factories import make_doc, make_task, problem_from
from ..problems import COMMON, decode_doc, problem_docs


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


def _prec(
    before: str, after: str, kind: str, offset: int = 0, scope: str = "both"
) -> dict:
    return {
        "before": before,
        "after": after,
        "kind": kind,
        "offset": offset,
        "scope": scope,
    }


def test_a_cycle_longer_than_zero_empties_its_tasks_at_once() -> None:
    """Tests that tasks whose precedences go round a cycle of positive
    length are given no start at once, however long the horizon (the
    propagation alone gains one length per pass and stops at its cap),
    with what they need; that a tight cycle of zero length keeps its
    starts; and that a mandatory task on such a cycle makes the problem
    infeasible without a solve."""
    from fsw_scheduler.model.plan import SolveStatus
    from fsw_scheduler.solving.solve import solve

    tasks = [
        make_task("a", 3),
        make_task("b", 4),
        make_task("c", 2),  # needs b
        make_task("d", 2),
        make_task("e", 3),
        make_task("free", 1),
    ]
    precedences = [
        _prec("a", "b", "lax", scope="at_least_first"),
        _prec("b", "a", "lax", 1, scope="at_least_first"),
        _prec("b", "c", "lax", scope="at_least_first"),
        # d -> e and back: 2 - 2 = 0, a tight cycle that holds.
        _prec("d", "e", "tight"),
        _prec("e", "d", "tight", -5),
    ]
    doc = make_doc(tasks, horizon=2880, precedences=precedences)
    domains = start_domains(problem_from(doc))
    for name in ("a", "b", "c"):
        assert domains[name].empty, (name, domains[name])
        assert domains[name].cause == "precedence"
    assert "cycle longer than zero" in domains["a"].detail
    assert "needs b" in domains["c"].detail
    for name in ("d", "e", "free"):
        assert not domains[name].empty, (name, domains[name])
    assert domains["e"].earliest == domains["d"].earliest + 2
    tasks[0]["schedule_cost"] = 0
    plan = solve(problem_from(doc), time_limit=10)
    assert plan.status is SolveStatus.INFEASIBLE
    assert plan.stats is not None and plan.stats.solver == "proof"
    assert {b.task for b in plan.why} == {"a", "b"}  # a needs b


def test_a_long_cycle_is_found_from_the_horizon() -> None:
    """Tests that 500 tasks in one lax cycle over a horizon of 100,000
    (the search for the cycle stops once a start difference passes the
    horizon, long before 500 rounds) all get no start, and that the same
    chain without the edge that closes it keeps every start."""
    count = 500
    tasks = [make_task(f"t{i}", 1) for i in range(count)]
    chain = [
        _prec(f"t{i}", f"t{i + 1}", "lax", scope="at_least_first")
        for i in range(count - 1)
    ]
    closing = _prec(f"t{count - 1}", "t0", "lax", scope="at_least_first")
    doc = make_doc(tasks, horizon=100_000, precedences=[*chain, closing])
    domains = start_domains(problem_from(doc))
    assert all(domain.empty for domain in domains.values())
    doc["precedences"] = chain
    domains = start_domains(problem_from(doc))
    assert not any(domain.empty for domain in domains.values())
    assert domains[f"t{count - 1}"].earliest == count - 1


@settings(COMMON, max_examples=150)
@given(doc=problem_docs(max_tasks=6, max_horizon=12), data=st.data())
def test_the_order_of_the_precedences_changes_no_bound(
    doc: dict, data: st.DataObject
) -> None:
    """Tests that the start domains are the same, bounds and emptiness,
    whatever the order in which the problem lists its precedences (the
    propagation goes along them in topological order and back)."""
    problem = decode_doc(doc)
    shuffled = problem.replace(
        precedences=tuple(data.draw(st.permutations(problem.precedences)))
    )
    first, second = start_domains(problem), start_domains(shuffled)
    for name, domain in first.items():
        other = second[name]
        assert domain.empty == other.empty, (name, domain, other)
        if not domain.empty:
            assert (domain.earliest, domain.latest) == (
                other.earliest,
                other.latest,
            ), (name, domain, other)
