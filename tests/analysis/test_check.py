"""Tests of the independent plan checker (fsw_scheduler.analysis.check)."""

from __future__ import annotations

import ast
import importlib
import math
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsw_scheduler.analysis import spans
from fsw_scheduler.analysis.check import CheckReport, check_plan, format_report
from fsw_scheduler.model.plan import (
    Activity,
    Objective,
    Plan,
    SolveStatus,
    objective_weight,
)

from ..factories import (
    ONE_OF_EACH,
    TABLE1_PLAN,
    make_doc,
    make_task,
    problem_from,
)

# The module, not the package's `check` function that shadows its name.
check = importlib.import_module("fsw_scheduler.analysis.check")

if TYPE_CHECKING:
    from fsw_scheduler.model.problem import Problem


def _problem(tasks: list[dict], **over: object) -> Problem:
    doc = make_doc(tasks, resources=ONE_OF_EACH)
    doc.update(over)
    return problem_from(doc)


def _plan(
    *activities: tuple[str, int, int],
    unscheduled: tuple[str, ...] = (),
    status: SolveStatus = SolveStatus.OPTIMAL,
    objective: Objective | None = None,
) -> Plan:
    return Plan(
        status,
        objective,
        tuple(Activity(*a) for a in activities),
        unscheduled,
    )


def _rules(report: CheckReport) -> list[str]:
    return [v.rule for v in report.violations]


def _only(report: CheckReport, rule: str) -> None:
    assert report.rules == {rule}, format_report(report)


# --------------------------------------------------------------------------
# The paper's Table 1


def test_table1_plan_is_valid(table1: Problem) -> None:
    """Tests that the paper's Table 1 plan passes with delay cost 359."""
    report = check_plan(table1, _plan(*TABLE1_PLAN))
    assert report.ok, format_report(report)
    assert report.objective == Objective(0, 359, 359)
    assert format_report(report).startswith("plan is valid")


def test_table1_plan_with_its_objective_is_valid(table1: Problem) -> None:
    """Tests that a plan reporting the right objective passes."""
    plan = _plan(*TABLE1_PLAN, objective=Objective(0, 359, 359))
    assert check_plan(table1, plan).ok


def test_table1_with_early_battery_charge(table1: Problem) -> None:
    """Tests that moving BatteryCharge breaks position and its tight link."""
    moved = [
        a if a[0] != "BatteryCharge" else (a[0], 5, 15) for a in TABLE1_PLAN
    ]
    report = check_plan(table1, _plan(*moved))
    assert report.rules == {"binary", "precedence"}
    assert {v.detail.split(":")[0] for v in report.of_rule("binary")} == {
        "'position' at t=5",
        "'position' at t=6",
    }


# --------------------------------------------------------------------------
# One test per rule


def test_valid_small_plan_has_no_violation() -> None:
    """Tests that a plan obeying every rule yields no violation."""
    problem = _problem(
        [
            make_task("a", uses={"cam": 1, "power": 6, "battery": 1}),
            make_task(
                "b",
                uses={"cam": 1, "power": 6, "battery": 1},
                feasible_interval=[2, 6],
            ),
            make_task("c", uses={"power": 4, "battery": 0.5}),
        ],
        precedences=[
            {"before": "a", "after": "b", "kind": "tight"},
            {"before": "a", "after": "c", "kind": "lax", "offset": -2},
        ],
    )
    report = check_plan(problem, _plan(("a", 0, 2), ("b", 2, 4), ("c", 0, 2)))
    assert report.ok, format_report(report)
    assert report.objective == Objective(0, 2, 2)


@pytest.mark.parametrize(
    ("activities", "unscheduled", "culprits"),
    [
        ((("a", 0, 2),), (), {"b"}),
        ((("a", 0, 2), ("b", 2, 4), ("a", 4, 6)), (), {"a"}),
        ((("a", 0, 2), ("b", 2, 4)), ("b",), {"b"}),
        ((("a", 0, 2),), ("b", "b"), {"b"}),
        ((("a", 0, 2), ("zz", 0, 1)), ("b", "yy"), {"zz", "yy"}),
    ],
    ids=["missing", "twice", "both", "dropped-twice", "unknown"],
)
def test_coverage(
    activities: tuple[tuple[str, int, int], ...],
    unscheduled: tuple[str, ...],
    culprits: set[str],
) -> None:
    """Tests that missing, repeated and unknown task ids break coverage."""
    problem = _problem([make_task("a"), make_task("b")])
    report = check_plan(problem, _plan(*activities, unscheduled=unscheduled))
    assert {v.task for v in report.of_rule("coverage")} == culprits


def test_length() -> None:
    """Tests that an activity whose end disagrees with its length fails."""
    problem = _problem([make_task("a", length=3)])
    report = check_plan(problem, _plan(("a", 1, 3)))
    _only(report, "length")
    assert report.violations[0].task == "a"
    assert report.violations[0].time == 1


@pytest.mark.parametrize(
    "activity", [("a", 1, 3), ("a", 9, 11)], ids=["early", "late"]
)
def test_horizon(activity: tuple[str, int, int]) -> None:
    """Tests that an activity outside [start, start + horizon) fails."""
    problem = _problem([make_task("a")], start=2, horizon=8)
    _only(check_plan(problem, _plan(activity)), "horizon")


def test_horizon_edges_are_valid() -> None:
    """Tests that the first and last placements in the horizon pass."""
    problem = _problem([make_task("a"), make_task("b")], start=2, horizon=8)
    assert check_plan(problem, _plan(("a", 2, 4), ("b", 8, 10))).ok


@pytest.mark.parametrize(
    ("reading", "start", "ok"),
    [
        ("task", 2, True),
        ("task", 4, True),
        ("task", 5, False),  # ends at 7 > 6
        ("task", 1, False),
        ("start", 6, True),  # only the start must be inside
        ("start", 7, False),
        ("start", 1, False),
    ],
)
def test_window_readings(reading: str, start: int, ok: bool) -> None:
    """Tests that each reading of the feasible interval is enforced."""
    problem = _problem(
        [make_task("a", feasible_interval=[2, 6])],
        feasible_interval_applies_to=reading,
    )
    report = check_plan(problem, _plan(("a", start, start + 2)))
    if ok:
        assert report.ok, format_report(report)
    else:
        _only(report, "window")


def test_window_task_override() -> None:
    """Tests that a task's own window reading overrides the problem's."""
    problem = _problem(
        [
            make_task(
                "a",
                feasible_interval=[2, 6],
                feasible_interval_applies_to="start",
            ),
            make_task(
                "b",
                feasible_interval=[2, 6],
                feasible_interval_applies_to="task",
            ),
        ],
        feasible_interval_applies_to="task",
    )
    plan = _plan(("a", 6, 8), ("b", 6, 8))
    report = check_plan(problem, plan)
    _only(report, "window")
    assert [v.task for v in report.violations] == ["b"]


def test_fixed_start() -> None:
    """Tests that a pinned task must start at its pin and be scheduled."""
    problem = _problem(
        [make_task("a", fixed_start=3), make_task("b", fixed_start=0)]
    )
    report = check_plan(problem, _plan(("a", 4, 6), unscheduled=("b",)))
    _only(report, "fixed_start")
    assert [(v.task, v.time) for v in report.violations] == [
        ("a", 4),
        ("b", 0),
    ]
    assert check_plan(problem, _plan(("a", 3, 5), ("b", 0, 2))).ok


def test_mandatory() -> None:
    """Tests that leaving out a task with schedule cost 0 fails."""
    problem = _problem([make_task("a", schedule_cost=0), make_task("b")])
    report = check_plan(problem, _plan(("b", 0, 2), unscheduled=("a",)))
    _only(report, "mandatory")
    assert report.violations[0].task == "a"
    assert check_plan(problem, _plan(("a", 0, 2), unscheduled=("b",))).ok


def test_binary() -> None:
    """Tests that two users of a binary resource cannot overlap."""
    problem = _problem(
        [
            make_task("a", uses={"cam": 1}),
            make_task("b", uses={"cam": 1}, length=3),
        ]
    )
    report = check_plan(problem, _plan(("a", 0, 2), ("b", 1, 4)))
    _only(report, "binary")
    (violation,) = report.violations
    assert violation.time == 1
    assert "a, b" in violation.detail
    assert check_plan(problem, _plan(("a", 0, 2), ("b", 2, 5))).ok


def test_binary_reports_every_overlap() -> None:
    """Tests that separate overlaps are reported separately."""
    problem = _problem(
        [
            make_task("a", uses={"cam": 1}, length=1),
            make_task("b", uses={"cam": 1}, length=6),
            make_task("c", uses={"cam": 1}, length=1),
        ]
    )
    report = check_plan(problem, _plan(("a", 1, 2), ("b", 0, 6), ("c", 4, 5)))
    assert [v.time for v in report.of_rule("binary")] == [1, 4]


def test_multiple() -> None:
    """Tests that the summed use of a multiple resource respects capacity."""
    problem = _problem(
        [
            make_task("a", uses={"power": 6}),
            make_task("b", uses={"power": 4}),
            make_task("c", uses={"power": 0.5}, length=1),
        ]
    )
    assert check_plan(problem, _plan(("a", 0, 2), ("b", 0, 2), ("c", 2, 3))).ok
    report = check_plan(problem, _plan(("a", 0, 2), ("b", 0, 2), ("c", 1, 2)))
    _only(report, "multiple")
    (violation,) = report.violations
    assert violation.time == 1
    assert "10.5" in violation.detail


def test_a_horizon_of_two_billion_units_is_walked_span_by_span() -> None:
    """Tests that the binary, window and capacity rules are judged span by
    span, not unit by unit: on a horizon of 2^31 - 1 units (a walk unit by
    unit would not end; past the longest horizon a problem is refused, so
    this one is stretched after validation, as a caller in Python could)
    an overlap, a use outside a window and an overrun of a capacity step
    are each named with their exact span."""
    end = 2**31 - 1
    far = 2_000_000_000
    problem = problem_from(
        make_doc(
            [
                make_task("a", 10, uses={"cam": 1, "power": 3}),
                make_task("b", 10, uses={"cam": 1, "power": 3}),
                make_task("c", 4, uses={"cam": 1}),
            ],
            resources={
                "binary": {"cam": {"available": [[0, far + 100]]}},
                "multiple": {"power": {"steps": [[0, 10], [far + 7, 4]]}},
            },
        )
    )
    problem = msgspec.structs.replace(problem, horizon=end)
    report = check_plan(
        problem,
        _plan(
            ("a", far, far + 10), ("b", far + 5, far + 15), ("c", end - 4, end)
        ),
    )
    details = sorted(v.detail for v in report.of_rule("binary"))
    assert details == [
        f"'cam' at t={far + 5}..{far + 9}: 2 users at once (a, b), at most 1 "
        "allowed",
        f"'cam' at t={end - 4}..{end - 1}: used by c outside its available "
        "windows",
    ]
    (over,) = report.of_rule("multiple")
    assert over.detail == (
        f"'power' at t={far + 7}..{far + 9}: use 6 exceeds capacity 4 (a, b)"
    )


def test_multiple_float_tolerance() -> None:
    """Tests that float rounding within 1e-9 is not a violation."""
    problem = _problem(
        [make_task(name, uses={"power": 0.1}) for name in "abc"],
        resources={"multiple": {"power": 0.3}},
    )
    plan = _plan(("a", 0, 2), ("b", 0, 2), ("c", 0, 2))
    assert 0.1 + 0.1 + 0.1 > 0.3  # the sum really does overshoot
    assert check_plan(problem, plan).ok


def test_consumable() -> None:
    """Tests that a consumable level below zero at any unit fails."""
    problem = _problem(
        [
            make_task("drain", uses={"battery": 2}, length=3),
            make_task("charge", uses={"battery": -3}, length=2),
        ]
    )
    # Charge first: 5 + 6 = 11, then drain 6 -> 5. Valid.
    assert check_plan(problem, _plan(("charge", 0, 2), ("drain", 2, 5))).ok
    # Drain first: 5 -> 3 -> 1 -> -1 at t=2, charge comes too late.
    report = check_plan(problem, _plan(("drain", 0, 3), ("charge", 4, 6)))
    _only(report, "consumable")
    (violation,) = report.violations
    assert violation.time == 2
    assert "-1" in violation.detail


def test_consumable_counts_within_the_unit() -> None:
    """Tests that generation in the same unit offsets consumption."""
    problem = _problem(
        [
            make_task("drain", uses={"battery": 4}, length=3),
            make_task("charge", uses={"battery": -1}, length=3),
        ],
    )
    # Net 3 per unit: 5 -> 2 -> -1 at t=1.
    report = check_plan(problem, _plan(("drain", 0, 3), ("charge", 0, 3)))
    assert [v.time for v in report.of_rule("consumable")] == [1]
    assert "lowest -4" in report.violations[0].detail


def test_consumable_reports_each_dip() -> None:
    """Tests that two separate dips below zero give two violations."""
    problem = _problem(
        [
            make_task("d1", uses={"battery": 6}, length=1),
            make_task("c1", uses={"battery": -2}, length=1),
            make_task("d2", uses={"battery": 3}, length=1),
        ],
    )
    # 5 -> -1 (t=0) -> 1 (t=1) -> -2 (t=2)
    report = check_plan(
        problem, _plan(("d1", 0, 1), ("c1", 1, 2), ("d2", 2, 3))
    )
    assert [v.time for v in report.of_rule("consumable")] == [0, 2]


@pytest.mark.parametrize(
    ("kind", "offset", "b_start", "ok"),
    [
        ("tight", 0, 2, True),
        ("tight", 0, 3, False),
        ("tight", 2, 4, True),
        ("tight", -1, 1, True),
        ("tight", -1, 2, False),
        ("lax", 0, 2, True),
        ("lax", 0, 5, True),
        ("lax", 0, 1, False),
        ("lax", -2, 0, True),
        ("lax", 3, 4, False),
    ],
)
def test_precedence(kind: str, offset: int, b_start: int, ok: bool) -> None:
    """Tests that tight (==) and lax (>=) precedences hold for any offset."""
    problem = _problem(
        [make_task("a"), make_task("b")],
        precedences=[
            {"before": "a", "after": "b", "kind": kind, "offset": offset}
        ],
    )
    report = check_plan(
        problem, _plan(("a", 0, 2), ("b", b_start, b_start + 2))
    )
    if ok:
        assert report.ok, format_report(report)
    else:
        _only(report, "precedence")
        assert report.violations[0].task == "b"


def test_precedence_uses_task_length() -> None:
    """Tests that precedences use the task's length, not the plan's end."""
    problem = _problem(
        [make_task("a"), make_task("b")],
        precedences=[{"before": "a", "after": "b", "kind": "tight"}],
    )
    report = check_plan(problem, _plan(("a", 0, 3), ("b", 2, 4)))
    _only(report, "length")


@pytest.mark.parametrize(
    ("scope", "scheduled", "ok"),
    [
        ("both", "ab", True),
        ("both", "", True),
        ("both", "a", False),
        ("both", "b", False),
        ("at_least_first", "ab", True),
        ("at_least_first", "", True),
        ("at_least_first", "a", True),
        ("at_least_first", "b", False),
    ],
)
def test_scope(scope: str, scheduled: str, ok: bool) -> None:
    """Tests that both and at_least_first scopes hold on every selection."""
    problem = _problem(
        [make_task("a"), make_task("b")],
        precedences=[
            {"before": "a", "after": "b", "kind": "tight", "scope": scope}
        ],
    )
    starts = {"a": 0, "b": 2}
    plan = _plan(
        *((name, starts[name], starts[name] + 2) for name in scheduled),
        unscheduled=tuple(name for name in "ab" if name not in scheduled),
    )
    report = check_plan(problem, plan)
    if ok:
        assert report.ok, format_report(report)
    else:
        _only(report, "scope")


def test_objective_recomputed() -> None:
    """Tests that the objective and W are recomputed per the problem format."""
    problem = _problem(
        [
            make_task("a", delay_cost=2, schedule_cost=4),
            make_task("b", delay_cost=3, schedule_cost=2),
            make_task("c", delay_cost=5, schedule_cost=5),
        ],
        start=4,
        horizon=6,
    )
    report = check_plan(
        problem, _plan(("a", 5, 7), ("c", 7, 9), unscheduled=("b",))
    )
    weight = objective_weight([2, 3, 5], 6)
    assert weight == 61
    assert report.objective == Objective(2, 2 * 1 + 5 * 3, 2 * 61 + 17)
    assert report.ok


def test_objective_mismatch() -> None:
    """Tests that a plan reporting a wrong objective fails."""
    problem = _problem([make_task("a", delay_cost=3)])
    plan = _plan(("a", 1, 3), objective=Objective(0, 0, 0))
    report = check_plan(problem, plan)
    _only(report, "objective")
    assert "delay_cost=3" in report.violations[0].detail


def test_every_violation_is_reported() -> None:
    """Tests that a plan breaking many rules gets all of them reported."""
    problem = _problem(
        [
            make_task("a", uses={"cam": 1, "power": 6, "battery": 3}),
            make_task(
                "b",
                uses={"cam": 1, "power": 6, "battery": 3},
                feasible_interval=[5, 9],
            ),
            make_task("m", schedule_cost=0),
            make_task("p", fixed_start=4),
            make_task("x"),
            make_task("y"),
        ],
        precedences=[
            {"before": "a", "after": "b", "kind": "lax"},
            {
                "before": "x",
                "after": "y",
                "kind": "lax",
                "scope": "at_least_first",
            },
        ],
    )
    plan = _plan(
        ("a", 0, 2),
        ("b", 1, 2),
        ("y", 9, 11),
        ("ghost", 0, 1),
        unscheduled=("m", "p", "x"),
        objective=Objective(0, 0, 0),
    )
    report = check_plan(problem, plan)
    assert set(_rules(report)) == {
        "coverage",
        "length",
        "horizon",
        "window",
        "fixed_start",
        "mandatory",
        "binary",
        "multiple",
        "consumable",
        "precedence",
        "scope",
        "objective",
    }
    # Every rule but the alternatives' (no group here: see below).
    assert set(_rules(report)) == set(check.RULES) - {"alternatives"}
    # Sorted by rule, in RULES order.
    order = [check.RULES.index(rule) for rule in _rules(report)]
    assert order == sorted(order)
    text = format_report(report)
    assert text.startswith(f"plan has {len(report.violations)} violations")
    assert "[scope] x:" in text
    assert "[binary] @t=1:" in text


@pytest.mark.parametrize(
    "status", [SolveStatus.INFEASIBLE, SolveStatus.UNKNOWN]
)
def test_planless_status_checks_coverage_only(status: SolveStatus) -> None:
    """Tests that infeasible/unknown plans are checked for coverage only."""
    problem = _problem([make_task("a", schedule_cost=0), make_task("b")])
    plan = _plan(unscheduled=("a", "b"), status=status)
    report = check_plan(problem, plan)
    assert report.ok, format_report(report)
    assert report.objective.unscheduled_cost == 1
    report = check_plan(problem, _plan(unscheduled=("a",), status=status))
    _only(report, "coverage")


def test_checker_is_independent() -> None:
    """Tests that check.py uses no solver code and no start_bounds."""
    assert check.__file__ is not None
    tree = ast.parse(Path(check.__file__).read_text())
    modules = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            modules.add((node.module or "").split(".")[0])
        elif isinstance(node, ast.Import):
            modules.update(alias.name.split(".")[0] for alias in node.names)
    assert modules.isdisjoint(
        {"pulp", "solve", "solving", "solvers", "fsw_scheduler"}
    )
    attributes = {
        node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)
    }
    assert "start_bounds" not in attributes


# --------------------------------------------------------------------------
# The mission model: alternatives and resources that change over time


def _grouped(cost: int = 2) -> Problem:
    """Two options, ``a1 + a2`` or ``b``, and a plain task ``c``."""
    return problem_from(
        make_doc(
            [
                make_task("a1", schedule_cost=cost),
                make_task("a2", schedule_cost=cost),
                make_task("b", schedule_cost=cost),
                make_task("c", schedule_cost=1),
            ],
            alternatives=[
                {
                    "id": "g",
                    "schedule_cost": cost,
                    "options": [["a1", "a2"], ["b"]],
                }
            ],
        )
    )


def test_an_option_is_all_or_none_and_one_option_at_most() -> None:
    """Tests that half an option, and two options, break ``alternatives``,
    each named with the group."""
    problem = _grouped()
    half = check_plan(problem, _plan(("a1", 0, 2), unscheduled=("c",)))
    _only(half, "alternatives")
    assert "'g' option 0" in half.violations[0].detail
    both = check_plan(
        problem,
        _plan(("a1", 0, 2), ("a2", 2, 4), ("b", 4, 6), unscheduled=("c",)),
    )
    _only(both, "alternatives")
    assert "options [0, 1]" in both.violations[0].detail


def test_a_group_left_out_costs_its_own_cost_once() -> None:
    """Tests the objective of groups: a group left out costs its schedule
    cost once (not its members'), an option chosen costs nothing, and the
    plan lists the group, not its members."""
    problem = _grouped(cost=3)
    weight = objective_weight([1, 1, 1, 1], 10)
    out = check_plan(problem, _plan(("c", 0, 2), unscheduled=("g",)))
    assert out.ok, format_report(out)
    assert out.objective == Objective(3, 0, 3 * weight)
    chosen = check_plan(problem, _plan(("b", 1, 3), unscheduled=("c",)))
    assert chosen.ok, format_report(chosen)
    assert chosen.objective == Objective(1, 1, weight + 1)


def test_group_listing_is_checked() -> None:
    """Tests ``coverage`` for groups: a group left out must be listed by
    its id, and a group with an option scheduled must not be."""
    problem = _grouped()
    silent = check_plan(problem, _plan(("c", 0, 2)))
    _only(silent, "coverage")
    assert silent.violations[0].task == "g"
    listed = check_plan(
        problem, _plan(("b", 0, 2), ("c", 2, 4), unscheduled=("g",))
    )
    _only(listed, "coverage")


def test_a_mandatory_group_needs_an_option() -> None:
    """Tests that a group of cost 0 left out breaks ``mandatory`` (and that
    its members, cost 0 too, are not mandatory one by one)."""
    problem = _grouped(cost=0)
    report = check_plan(problem, _plan(("c", 0, 2), unscheduled=("g",)))
    _only(report, "mandatory")
    assert [v.task for v in report.violations] == ["g"]
    assert check_plan(problem, _plan(("b", 0, 2), ("c", 2, 4))).ok


def _changing(**resources: object) -> Problem:
    return problem_from(
        make_doc(
            [
                make_task("x", 2, uses={"cam": 1, "power": 2, "battery": 2}),
                make_task("y", 2, uses={"power": 2}),
            ],
            resources={
                "binary": {"cam": {"available": [[2, 6]]}},
                "multiple": {"power": {"steps": [[0, 4], [5, 2]]}},
                "consumable": {
                    "battery": {"initial": 1, "external": [[0, 1]]}
                },
            }
            | resources,
        )
    )


def test_a_binary_user_runs_only_inside_a_window() -> None:
    """Tests that a binary resource is free inside its windows and refused
    outside (the window is half-open)."""
    problem = _changing()
    assert check_plan(problem, _plan(("x", 2, 4), ("y", 8, 10))).ok
    late = check_plan(problem, _plan(("x", 5, 7), ("y", 0, 2)))
    _only(late, "binary")
    assert "outside its available windows" in late.of_rule("binary")[0].detail
    assert late.of_rule("binary")[0].time == 6


def test_a_capacity_step_holds_in_its_units_only() -> None:
    """Tests that two users of 2 fit under the first step (4) and break the
    second (2), from its first unit on."""
    problem = _changing()
    assert check_plan(problem, _plan(("x", 2, 4), ("y", 2, 4))).ok
    report = check_plan(problem, _plan(("x", 4, 6), ("y", 4, 6)))
    _only(report, "multiple")
    assert report.violations[0].time == 5
    assert "capacity 2" in report.violations[0].detail


def test_the_external_rate_charges_and_drains() -> None:
    """Tests the level with an external rate: the charge lets a consumer
    run that the initial level alone would not allow, and a drain with no
    task at all takes the level below 0."""
    problem = _changing()
    # level: 1 +1 (t=0), +1 (t=1), then x takes 2 and gets 1 per unit.
    assert check_plan(problem, _plan(("x", 2, 4), ("y", 6, 8))).ok
    early = _changing(consumable={"battery": {"initial": 1}})
    report = check_plan(early, _plan(("x", 2, 4), ("y", 6, 8)))
    _only(report, "consumable")
    drain = _changing(
        consumable={"battery": {"initial": 2, "external": [[3, -1]]}}
    )
    report = check_plan(drain, _plan(("y", 0, 2), unscheduled=("x",)))
    _only(report, "consumable")
    assert report.violations[0].time == 5


@settings(max_examples=400, deadline=None)
@given(
    level=st.sampled_from([-3.0, -0.5, 0.0, 0.1, 1.0, 2.5, 7.0]),
    rate=st.sampled_from([-2.0, -0.3, -0.1, 0.0, 0.1, 0.7, 3.0]),
    top=st.sampled_from([math.inf, 0.0, 2.0, 7.0]),
    units=st.integers(min_value=1, max_value=40),
)
def test_a_span_is_judged_as_unit_by_unit(
    level: float, rate: float, top: float, units: int
) -> None:
    """Tests that the closed-form span of a consumable gives the units
    below zero, the first and lowest levels and the level after it that
    the unit by unit sum gives."""
    level = min(top, level)
    t0 = 100
    walked, below = level, []
    for t in range(t0, t0 + units):
        walked = min(top, walked + rate)
        if walked < -spans.TOLERANCE:
            below.append((t, walked))
    hits = spans.below_zero(t0, t0 + units, level, rate, top)
    runs = list(spans.runs(hits))
    if not below:
        assert hits == []
    else:
        assert len(runs) == 1
        run = runs[0]
        assert (run[0].t, run[-1].last) == (below[0][0], below[-1][0])
        assert [u for u, _ in below] == list(
            range(below[0][0], below[-1][0] + 1)
        )
        assert run[0].value == pytest.approx(below[0][1], abs=1e-9)
        assert min(h.value for h in run) == pytest.approx(
            min(v for _, v in below), abs=1e-9
        )
    assert spans.level_after(level, rate, units, top) == pytest.approx(
        walked, abs=1e-9
    )


def test_a_long_horizon_is_checked_in_the_plan_s_size() -> None:
    """Tests that a battery over the longest horizon is judged span by
    span: a drain found with its span, first and lowest levels."""
    doc = {
        "horizon": 100_000,
        "resources": {"consumable": {"battery": 10}},
        "tasks": [
            {
                "id": "a",
                "length": 75_000,
                "delay_cost": 1,
                "schedule_cost": 1,
                "uses": {"battery": 0.0002},
            },
            {
                "id": "b",
                "length": 50_000,
                "delay_cost": 1,
                "schedule_cost": 1,
                "uses": {"battery": 0.0002},
            },
        ],
    }
    problem = problem_from(doc)
    plan = Plan(
        status=SolveStatus.FEASIBLE,
        objective=None,
        activities=(Activity("a", 0, 75_000), Activity("b", 0, 50_000)),
    )
    report = check_plan(problem, plan)
    # Both drain 4e-4 a unit: 10 is gone after 25,000 units and -10 at
    # 50,000; a alone drains 2e-4 a unit to -15 at 75,000, where the
    # level stays to the end.
    consumable = [v for v in report.violations if v.rule == "consumable"]
    assert len(consumable) == 1
    assert "t=25000..99999" in consumable[0].detail
    assert "lowest -15" in consumable[0].detail
