"""Tests of the levels written on the starts in the disjunctive relaxation
(:meth:`RelaxedModel._timed_level_rows`) and the runs that add them."""

from __future__ import annotations

from hypothesis import assume, given, settings

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.solving.relaxed import (
    RelaxedModel,
    applies,
    lowest_units,
    relaxed_bound,
)

from ..factories import make_doc, make_task, problem_from
from ..problems import (
    COMMON,
    brute_force,
    decode_doc,
    plan_of,
    problem_docs,
    row_holds,
    show,
    warm_starts,
)


def _battery_day() -> dict:
    """A charge only from unit 10 on, and two consumers that would rather
    start at once but together need more than the store holds: the
    relaxation's first optimum runs both at once and overdraws it."""
    return make_doc(
        [
            make_task(
                "gen",
                4,
                uses={"cam": 1, "bat": -3},
                feasible_interval=[10, 16],
            ),
            make_task("a", 3, delay_cost=5, uses={"bat": 2}),
            make_task("b", 3, delay_cost=5, uses={"bat": 2}),
        ],
        horizon=20,
        resources={"binary": ["cam"], "consumable": {"bat": 7}},
    )


def test_lowest_units_are_the_first_and_the_lowest_below_zero() -> None:
    """Tests that a stretch below zero gives its first unit and the unit
    of its lowest level."""
    problem = problem_from(_battery_day())
    plan = plan_of(problem, {"gen": 10, "a": 0, "b": 0})
    # Level after unit t: 7 - 4 (t + 1) for t <= 2 (two consumers), then
    # -5 until the charge from unit 10 on (+3 a unit: -2 after unit 10,
    # +1 after 11): below zero over units 1-10, lowest (-5) first at 2.
    assert lowest_units(problem, plan) == [1, 2]
    # Spread: also the stretch's last unit (10) and one every
    # len // 4 = 2 units across it (1, 3, 5, 7, 9).
    assert lowest_units(problem, plan, spread=4) == [1, 2, 3, 5, 7, 9, 10]
    fine = plan_of(problem, {"gen": 10, "a": 0, "b": 10})
    assert check_plan(problem, fine).ok
    assert lowest_units(problem, fine) == []
    assert lowest_units(problem, fine, spread=4) == []


@settings(COMMON, max_examples=150)
@given(doc=problem_docs(max_tasks=4, max_horizon=8, capacities=True))
def test_every_plan_satisfies_the_timed_level_rows(doc: dict) -> None:
    """Tests that the rows written at every unit, with the columns filled
    from a feasible plan as a MIP start fills them, hold: they cut off no
    plan. So do the model's other rows: CBC drops a start that breaks
    one."""
    problem = decode_doc(doc)
    domains = start_domains(problem)
    assume(applies(problem, domains))
    plain = RelaxedModel(problem, domains)
    units = range(problem.start, problem.start + problem.horizon)
    built = RelaxedModel(problem, domains, checkpoints=units)
    added = built.program.rows[plain.program.num_rows :]
    assume(added)
    for placed in warm_starts(problem, built.constraints.twins):
        values = built.vars.initial(placed, built.program.num_columns)
        for terms, sense, rhs in built.program.rows:
            assert row_holds(terms, sense, rhs, values), (show(doc), placed)


@settings(COMMON, max_examples=80)
@given(doc=problem_docs(max_tasks=4, max_horizon=8, capacities=True))
def test_levels_at_every_unit_make_the_relaxation_exact(doc: dict) -> None:
    """Tests that with the levels written at every unit (consumables
    without a capacity are then exact), the relaxation's optimum is the
    exhaustive search's, and a valid plan."""
    # The drawn stores without their capacity (a full store loses charge,
    # which the rows over-count: with one they only relax the level).
    for name, spec in doc["resources"]["consumable"].items():
        if isinstance(spec, dict):
            doc["resources"]["consumable"][name] = spec["initial"]
    problem = decode_doc(doc)
    domains = start_domains(problem)
    assume(applies(problem, domains))
    best = brute_force(problem)
    assume(best is not None)
    assert best is not None
    incumbent = plan_of(problem, best[1])
    units = tuple(range(problem.start, problem.start + problem.horizon))
    answer = relaxed_bound(
        problem, incumbent, domains, time_limit=None, levels=units
    )
    assert answer.plan is not None, (show(doc), answer.said)
    assert answer.plan.objective is not None
    assert answer.plan.objective.total == best[0].total
    assert check_plan(problem, answer.plan).ok


def test_a_broken_level_is_written_and_solved_again() -> None:
    """Tests that when the relaxation's optimum overdraws the battery the
    level there joins the program and the next optimum is a valid plan,
    the part's optimum."""
    problem = problem_from(_battery_day())
    domains = start_domains(problem)
    incumbent = plan_of(problem, {"gen": 10, "a": 0, "b": 12})
    assert check_plan(problem, incumbent).ok
    answer = relaxed_bound(problem, incumbent, domains, time_limit=None)
    assert answer.levels, answer.said
    assert answer.plan is not None and answer.plan.objective is not None
    assert answer.plan.status is SolveStatus.OPTIMAL
    assert "levels at" in answer.said
    best = brute_force(problem)
    assert best is not None
    assert answer.plan.objective.total == best[0].total
    assert answer.bound == answer.plan.objective.total


def test_levels_at_every_unit_are_exact_on_a_tight_charge() -> None:
    """Tests the rows of a generator always started by then, charging
    unit by unit while a heavy consumer waits for it: the relaxation with
    every level written finds exhaustive search's optimum, no earlier."""
    doc = make_doc(
        [
            make_task("gen", 4, uses={"cam": 1, "bat": -3}, fixed_start=10),
            make_task("a", 3, delay_cost=5, uses={"bat": 2}),
            make_task("b", 3, delay_cost=5, uses={"bat": 4}),
        ],
        horizon=20,
        resources={"binary": ["cam"], "consumable": {"bat": 7}},
    )
    problem = problem_from(doc)
    domains = start_domains(problem)
    best = brute_force(problem)
    assert best is not None
    units = tuple(range(problem.start, problem.start + problem.horizon))
    answer = relaxed_bound(
        problem,
        plan_of(problem, best[1]),
        domains,
        time_limit=None,
        levels=units,
    )
    assert answer.plan is not None and answer.plan.objective is not None
    assert answer.plan.objective.total == best[0].total
