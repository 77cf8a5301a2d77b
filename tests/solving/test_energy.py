"""Tests of the busy-time and energy rows and of the pair count that
picks a model."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import TYPE_CHECKING

from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.solving.ilp.disjunctive.constraints import Constraints
from fsw_scheduler.solving.ilp.disjunctive.energy import (
    add_busy_rows,
    add_energy_rows,
)
from fsw_scheduler.solving.ilp.disjunctive.rule import minimal_sets, pick
from fsw_scheduler.solving.ilp.disjunctive.variables import Variables
from fsw_scheduler.solving.ilp.program import GE, LE, Program
from fsw_scheduler.solving.solve import solve

from ..factories import crowded_camera, make_doc, make_task, problem_from
from ..problems import (
    COMMON,
    Assignment,
    decode_doc,
    is_feasible,
    problem_docs,
    show,
    start_ok,
)

if TYPE_CHECKING:
    from collections.abc import Iterator

    from fsw_scheduler.model.problem import Problem


def _busy_program(doc: dict) -> tuple[Program, Variables]:
    """The busy-time rows of ``doc``'s problem alone, over its columns."""
    problem = decode_doc(doc)
    program = Program()
    variables = Variables(program, problem, start_domains(problem))
    users = Constraints(program, problem, variables)._users
    del program.rows[:]
    add_busy_rows(program, variables, problem, users)
    return program, variables


def _holds(program: Program, values: list[float]) -> bool:
    for terms, sense, rhs in program.rows:
        assert sense == GE
        if sum(c * values[col] for col, c in terms.items()) < rhs - 1e-6:
            return False
    return True


def _feasible_plans(
    problem: Problem, program: Program, variables: Variables
) -> Iterator[tuple[Assignment, list[float]]]:
    """Every feasible assignment of ``problem``, found by enumeration,
    with the column values it gives ``program``."""
    options = []
    for task in problem.tasks:
        starts: list[int | None] = [
            s
            for s in range(problem.start, problem.start + problem.horizon)
            if start_ok(problem, task, s)
        ]
        options.append([*starts, None])
    ids = [task.id for task in problem.tasks]
    for combo in itertools.product(*options):
        assignment: Assignment = dict(zip(ids, combo, strict=True))
        if not is_feasible(problem, assignment):
            continue
        placed = {k: v for k, v in assignment.items() if v is not None}
        yield assignment, variables.initial(placed, program.num_columns)


@settings(COMMON, max_examples=80)
@given(doc=problem_docs(max_tasks=4, max_horizon=8))
def test_busy_and_energy_rows_hold_in_every_feasible_plan(doc: dict) -> None:
    """Tests that every feasible assignment, found by enumeration,
    satisfies every busy-time row and every energy row (the rows cut no
    plan)."""
    doc["resources"]["consumable"] = {}
    problem = decode_doc(doc)
    busy, busy_vars = _busy_program(doc)
    energy, energy_vars = _energy_program(doc)
    for assignment, values in _feasible_plans(problem, busy, busy_vars):
        assert _holds(busy, values), show(doc) + f"\n{assignment}"
    for assignment, values in _feasible_plans(problem, energy, energy_vars):
        assert _within(energy, values), show(doc) + f"\n{assignment}"


def test_busy_row_cuts_overlapping_starts_on_one_machine() -> None:
    """Tests that three mandatory users of a camera, all at their earliest
    start, violate a busy row, and that a sequence of them does not."""
    tasks = [
        make_task(name, length=2, schedule_cost=0, uses={"cam": 1})
        for name in ("a", "b", "c")
    ]
    doc = make_doc(tasks, horizon=8, resources={"binary": ["cam"]})
    program, variables = _busy_program(doc)
    together = variables.initial({"a": 0, "b": 0, "c": 0}, program.num_columns)
    in_turn = variables.initial({"a": 0, "b": 2, "c": 4}, program.num_columns)
    assert not _holds(program, together)
    assert _holds(program, in_turn)


def _energy_program(doc: dict) -> tuple[Program, Variables]:
    """The energy rows of ``doc``'s problem alone, over its columns."""
    problem = decode_doc(doc)
    program = Program()
    variables = Variables(program, problem, start_domains(problem))
    add_energy_rows(program, variables, problem)
    return program, variables


def _within(program: Program, values: list[float]) -> bool:
    for terms, sense, rhs in program.rows:
        assert sense == LE
        if sum(c * values[col] for col, c in terms.items()) > rhs + 1e-6:
            return False
    return True


def test_an_overloaded_camera_gets_a_row_on_the_scheduled_columns() -> None:
    """Tests that a camera asked for 40 units over a horizon of 10 gets a
    row over the "scheduled" columns alone that keeps one task, and that
    a camera asked for what it has gets none (the LP keeps every task
    only where every task fits)."""
    program, variables = _energy_program(crowded_camera(3))
    scheduled = {variables.scheduled(name) for name in variables.domains}
    assert program.rows
    for terms, sense, rhs in program.rows:
        assert sense == LE and set(terms) <= scheduled
    keep_all = [0.0] * program.num_columns
    for column in scheduled:
        keep_all[column] = 1.0
    assert not _within(program, keep_all)
    keep_one = [0.0] * program.num_columns
    keep_one[variables.scheduled("long")] = 1.0
    assert _within(program, keep_one)
    tasks = [make_task(f"t{k}", 5, uses={"camera": 1}) for k in range(2)]
    fits = make_doc(tasks, horizon=10, resources={"binary": ["camera"]})
    assert not _energy_program(fits)[0].rows


def _brute_minimal_sets(
    amounts: list[float], capacity: float
) -> tuple[int, int]:
    fitting = [a for a in amounts if 0 < a <= capacity]
    pairs = sum(
        1 for a, b in itertools.combinations(fitting, 2) if a + b > capacity
    )
    triples = sum(
        1
        for trio in itertools.combinations(fitting, 3)
        if sum(trio) > capacity
        and all(a + b <= capacity for a, b in itertools.combinations(trio, 2))
    )
    return pairs, triples


@settings(COMMON, max_examples=200)
@given(
    amounts=st.lists(st.integers(0, 12), max_size=8),
    capacity=st.integers(1, 12),
)
def test_minimal_sets_counts_as_enumeration(
    amounts: list[int], capacity: int
) -> None:
    """Tests that minimal_sets counts the over-capacity pairs and the
    triples with no pair over, as an enumeration does."""
    floats = [float(a) for a in amounts]
    assert minimal_sets(floats, capacity) == _brute_minimal_sets(
        floats, capacity
    )


def _on_power(amounts: list[float]) -> str:
    """The model picked for tasks drawing ``amounts`` of a capacity 80."""
    tasks = [
        make_task(f"t{k}", uses={"power": amount})
        for k, amount in enumerate(amounts)
    ]
    problem = problem_from(
        make_doc(tasks, horizon=40, resources={"multiple": {"power": 80}})
    )
    return pick(problem, start_domains(problem))


def test_rule_keeps_time_indexed_when_pairs_are_rare() -> None:
    """Tests that a multiple resource whose over-capacity sets are almost
    all triples gets the time-indexed model, and one with a pair in four
    the disjunctive one."""
    # 30 + 30 + 30 > 80 (56 triples); 71 + 30 and 71 + 71 > 80 (17 pairs).
    some_pairs = [30.0] * 8 + [71.0, 71.0]
    assert minimal_sets(some_pairs, 80) == (17, 56)
    assert _on_power(some_pairs) == "disjunctive"
    # 45 + 45 > 80 is the only pair; 286 + 2 * 78 triples.
    one_pair = [30.0] * 13 + [45.0, 45.0]
    assert minimal_sets(one_pair, 80) == (1, 442)
    assert _on_power(one_pair) == "time-indexed"


#: broad seed 133's b15-binary-3 (tools/bench): 13 camera tasks asking
#: 426 units of a horizon of 336. CP-SAT's optimum: 130,218.
OVERLOADED_CAMERA = Path(__file__).parent / "data" / "overloaded-camera.json"


def test_the_overloaded_camera_day_is_proved() -> None:
    """Tests that the day is proved at CP-SAT's optimum: without the
    energy rows CBC's bound stayed at 6,126 for 20 s (`feasible`)."""
    problem = decode_problem(OVERLOADED_CAMERA.read_bytes())
    plan = solve(problem, time_limit=30)
    assert plan.status is SolveStatus.OPTIMAL, plan.stats
    assert plan.objective is not None and plan.objective.total == 130218
