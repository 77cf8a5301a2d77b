"""Tests of the kept sets the solver refutes (:mod:`fsw_scheduler.
solving.refuted`) and of the no-goods they give the kept-set search."""

from __future__ import annotations

import functools
import json
import time
from pathlib import Path
from typing import TYPE_CHECKING

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.bounds import kept_set_bound
from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import greedy_plan
from fsw_scheduler.analysis.proofs import forced_tasks, with_needs
from fsw_scheduler.model.plan import Plan, SolveStatus
from fsw_scheduler.model.problem import Problem, decode_problem
from fsw_scheduler.solving.ilp import solve_ilp
from fsw_scheduler.solving.refuted import Refuted, asked, refuted

from ..problems import (
    COMMON,
    brute_force,
    candidates,
    decode_doc,
    joint_ok,
    plan_of,
    problem_docs,
)

if TYPE_CHECKING:
    from fsw_scheduler.analysis.keptset import Nogood

#: ``tools/fuzz --large`` seed 1462: 38 tasks over H = 120, three
#: cameras, two power lines (one halved over [40, 80)). The kept-set
#: relaxation keeps 32 tasks, which no plan holds; CP-SAT proves the
#: optimum, 175,027 (31 kept, 13 units of schedule cost left out).
DENSE_DAY = Path(__file__).parent / "data" / "dense-day-l1462.json"
OPTIMUM = 175_027

RUN = functools.partial(solve_ilp, solver="cbc")

#: The caller's deadline the dense day's tests give (seconds): the rounds
#: take :data:`~fsw_scheduler.solving.refuted.SHARE` of it and end as
#: soon as a set has a plan (about 5 s here). At 15 s (5.25 s for the
#: rounds) the next set's solve was cut on a loaded machine (two test
#: workers) and "could not say".
DEADLINE_S = 60.0


def _nothing_kept(problem: Problem) -> Plan | None:
    """The plan that keeps no task, when it is valid (no task required)."""
    plan = plan_of(problem, {t.id: None for t in problem.tasks})
    report = check_plan(problem, plan)
    if not report.ok:
        return None
    return plan.replace(objective=report.objective)


def _rounds(
    problem: Problem, start: Plan, seconds: float = DEADLINE_S
) -> Refuted:
    """The rounds of :func:`refuted` from ``start`` and its relaxation,
    with ``seconds`` to the caller's deadline."""
    domains = start_domains(problem)
    proof = kept_set_bound(problem, start, domains)
    return refuted(
        problem, start, domains, proof, RUN, time.perf_counter() + seconds
    )


def test_a_dense_day_gets_the_plan_its_next_kept_set_allows() -> None:
    """Tests that on a day where the relaxation keeps a set no plan
    holds, the set is refuted, the bound rises to what the next set
    costs, and the next set's plan is the optimum (the start heuristic
    leaves out 20 units of schedule cost, the optimum 13)."""
    problem = decode_problem(DENSE_DAY.read_text())
    domains = start_domains(problem)
    start = greedy_plan(problem)
    assert start is not None and start.objective is not None
    assert start.objective.unscheduled_cost > 13
    proof = kept_set_bound(problem, start, domains)
    assert proof.lowest is not None and proof.lowest < 160_000
    asked = refuted(
        problem, start, domains, proof, RUN, time.perf_counter() + DEADLINE_S
    )
    assert asked.plan is not None and asked.plan.objective is not None
    assert check_plan(problem, asked.plan).ok
    assert asked.plan.objective.unscheduled_cost == 13
    assert asked.plan.objective.total >= OPTIMUM
    assert asked.proof.lowest is not None
    assert 173_000 <= asked.proof.lowest <= OPTIMUM
    assert len(asked.nogoods) == 1
    assert asked.said.startswith("1 kept set refuted; the next, of 31 tasks")


def test_nothing_is_asked_when_the_start_keeps_what_the_bound_keeps() -> None:
    """Tests that a start plan as good as the relaxation's kept set (the
    dense day's optimum, leaving out what the bound leaves out) asks the
    solver nothing."""
    problem = decode_problem(DENSE_DAY.read_text())
    domains = start_domains(problem)
    start = greedy_plan(problem)
    assert start is not None
    asked = _rounds(problem, start)
    assert asked.plan is not None
    again = refuted(
        problem,
        asked.plan,
        domains,
        kept_set_bound(problem, asked.plan, domains, nogoods=asked.nogoods),
        RUN,
        time.perf_counter() + DEADLINE_S,
    )
    assert again.said == ""
    assert again.plan is None and again.nogoods == ()


def _holds(problem: Problem, nogood: Nogood) -> bool:
    """True when no valid plan keeps every task of the no-good's first
    set and leaves out every task of its second (exhaustive search)."""
    kept, out = nogood
    for starts in candidates(problem):
        if (
            all(starts[n] is not None for n in kept)
            and all(starts[n] is None for n in out)
            and joint_ok(problem, starts)
        ):
            return False
    return True


@st.composite
def _crowded_docs(draw: st.DrawFn) -> dict:
    """Small crowded days: tasks with short windows on a camera and a
    power line two of them overrun, sometimes a battery one of them
    charges, and precedences (the relaxation's rows count energy per
    interval, so it keeps sets that no order fits)."""
    horizon = draw(st.integers(4, 8))
    tasks = []
    count = draw(st.integers(4, 7))
    # Camera days: energy per interval fits where no order does.
    camera = draw(st.booleans())
    for k in range(count):
        length = draw(st.integers(1, 3))
        uses: dict[str, float] = {}
        if camera or draw(st.integers(0, 3)):
            uses["camera"] = 1
        if draw(st.integers(0, 2)):
            uses["power"] = draw(st.sampled_from([4, 6, 7]))
        if draw(st.integers(0, 3)) == 0:
            uses["battery"] = draw(st.sampled_from([-2, 1, 2]))
        low = draw(st.integers(0, horizon - length))
        high = min(horizon, low + length + draw(st.integers(0, 2)))
        tasks.append(
            {
                "id": f"t{k}",
                "length": length,
                "delay_cost": draw(st.integers(0, 3)),
                "schedule_cost": draw(st.integers(1, 4)),
                "uses": uses,
                "feasible_interval": [low, high],
            }
        )
    precedences = []
    if count > 1 and draw(st.booleans()):
        a, b = draw(st.permutations(range(count)))[:2]
        precedences.append(
            {
                "before": f"t{min(a, b)}",
                "after": f"t{max(a, b)}",
                "kind": draw(st.sampled_from(["lax", "tight"])),
                "scope": draw(st.sampled_from(["both", "at_least_first"])),
                "offset": 0,
            }
        )
    return {
        "horizon": horizon,
        "feasible_interval_applies_to": "task",
        "resources": {
            "binary": ["camera"],
            "multiple": {"power": 10},
            "consumable": {"battery": 2},
        },
        "tasks": tasks,
        "precedences": precedences,
    }


@settings(COMMON, max_examples=150)
@given(
    doc=st.one_of(
        _crowded_docs(),
        problem_docs(max_tasks=5, max_horizon=8, capacities=True),
    ),
)
def test_refutations_are_proofs_and_the_bound_stays_a_bound(doc: dict) -> None:
    """Tests, against exhaustive search on small days started from the
    plan that keeps nothing, that every no-good holds of every plan,
    that the bound never rises above the optimum, that a plan proved
    optimal is, and that a plan found is valid."""
    problem = decode_doc(doc)
    if problem.alternatives:
        return
    start = _nothing_kept(problem)
    if start is None:
        return
    domains = start_domains(problem)
    proof = kept_set_bound(problem, start, domains)
    if proof.bound is None:
        return
    asked = refuted(
        problem, start, domains, proof, RUN, time.perf_counter() + 30
    )
    best = brute_force(problem)
    assert best is not None  # the start plan is one
    optimum = best[0].total
    for nogood in asked.nogoods:
        assert _holds(problem, nogood), (doc, nogood)
    assert asked.proof.lowest is not None
    assert asked.proof.lowest <= optimum, (doc, asked)
    proved = asked.proof.plan
    if proved is not None:
        assert proved.objective is not None
        assert check_plan(problem, proved).ok, (doc, asked)
        assert proved.objective.total == optimum, (doc, asked)
    if asked.plan is not None:
        report = check_plan(problem, asked.plan)
        assert report.ok, (doc, asked.plan)
        assert asked.plan.status is SolveStatus.FEASIBLE


@settings(COMMON, max_examples=200)
@given(
    doc=st.one_of(
        _crowded_docs(),
        problem_docs(max_tasks=5, max_horizon=8, capacities=True),
    ),
    mask=st.lists(st.integers(0, 3), min_size=7, max_size=7),
)
def test_a_kept_set_is_refuted_only_when_no_plan_keeps_it(
    doc: dict, mask: list[int]
) -> None:
    """Tests, against exhaustive search, each answer about a drawn set of
    tasks: a no-good is a subset of the set that no valid plan keeps
    while it leaves out every task of its second side; a plan keeps the
    whole set and is valid; and on days this small the solver always
    says one or the other (drawn sets hold the tasks every plan must
    hold and what their tasks need, as the relaxation's do)."""
    problem = decode_doc(doc)
    if problem.alternatives:
        return
    domains = start_domains(problem)
    # As the relaxation's sets do, every drawn set holds the tasks every
    # plan must hold and what its tasks need (precedence scopes).
    drawn = {
        t.id for t, keep in zip(problem.tasks, mask, strict=False) if keep
    }  # most tasks: crowded sets
    kept = frozenset(with_needs(problem, drawn | forced_tasks(problem)))
    if not kept or any(domains[n].empty for n in kept):
        return
    answer = asked(problem, kept, RUN, 20.0)
    if answer.nogood is not None:
        assert answer.plan is None
        assert answer.nogood[0] <= kept
        assert _holds(problem, answer.nogood), (doc, kept, answer)
    elif answer.plan is not None:
        assert check_plan(problem, answer.plan).ok, (doc, kept, answer)
        assert kept <= set(answer.plan.starts())
    else:
        raise AssertionError((doc, kept, answer))


def _camera_trap() -> Problem:
    """A camera day where ``a``, ``b`` and ``c`` fit the camera's time
    between 0 and 5 (3 + 1 + 1 units) but in no order: ``a`` takes three
    units in a row, ``b`` one of units 1-2 and ``c`` one of units 3-4;
    with ``x`` and ``y`` the camera is asked 8 units of 7."""
    camera = {"camera": 1}
    return decode_problem(
        json.dumps(
            {
                "horizon": 7,
                "feasible_interval_applies_to": "task",
                "resources": {"binary": ["camera"]},
                "tasks": [
                    {"id": "a", "length": 3, "delay_cost": 1,
                     "schedule_cost": 3, "uses": camera,
                     "feasible_interval": [0, 5]},
                    {"id": "b", "length": 1, "delay_cost": 1,
                     "schedule_cost": 2, "uses": camera,
                     "feasible_interval": [1, 3]},
                    {"id": "c", "length": 1, "delay_cost": 1,
                     "schedule_cost": 2, "uses": camera,
                     "feasible_interval": [3, 5]},
                    {"id": "x", "length": 1, "delay_cost": 1,
                     "schedule_cost": 1, "uses": camera},
                    {"id": "y", "length": 2, "delay_cost": 1,
                     "schedule_cost": 4, "uses": camera},
                ],
            }
        )
    )  # fmt: skip


def test_the_solver_refutes_a_set_the_cheap_proofs_miss() -> None:
    """Tests that a set whose energy fits but whose order does not is
    refuted by the solver, and that the kept-set search then keeps a set
    without it at a higher bound that is still a bound."""
    problem = _camera_trap()
    trio = frozenset({"a", "b", "c"})
    answer = asked(problem, trio, RUN, 10.0)
    assert answer.solved
    assert answer.nogood == (trio, frozenset())
    domains = start_domains(problem)
    start = _nothing_kept(problem)
    assert start is not None
    before = kept_set_bound(problem, start, domains)
    assert before.kept is not None and trio <= before.kept
    after = kept_set_bound(problem, start, domains, nogoods=[answer.nogood])
    assert after.kept is not None and not trio <= after.kept
    assert before.lowest is not None and after.lowest is not None
    assert after.lowest > before.lowest
    best = brute_force(problem)
    assert best is not None and after.lowest <= best[0].total


def test_the_rounds_on_the_camera_trap_reach_the_optimal_choice() -> None:
    """Tests that from the plan that keeps nothing, the rounds refute the
    trio and end on a set the solver places, leaving out what the
    optimum leaves out, with a bound that is one."""
    problem = _camera_trap()
    start = _nothing_kept(problem)
    assert start is not None
    asked_ = _rounds(problem, start)
    best = brute_force(problem)
    assert best is not None
    assert asked_.nogoods
    for nogood in asked_.nogoods:
        assert {"a", "b", "c"} <= nogood[0]
        assert _holds(problem, nogood)
    assert asked_.plan is not None and asked_.plan.objective is not None
    assert check_plan(problem, asked_.plan).ok
    assert asked_.plan.objective.unscheduled_cost == best[0].unscheduled_cost
    assert asked_.proof.lowest is not None
    assert asked_.proof.lowest <= best[0].total
