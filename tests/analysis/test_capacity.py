"""Tests of consumables with a capacity, layer by layer.

A consumable written ``{"initial": 8, "max": 10}`` never holds more than
``max``: the level at the end of unit ``t`` is ``min(max, level at t-1 -
net use in t)``, and generation beyond the capacity is lost. The plain
number form means no capacity (the behaviour before capacities existed).
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import msgspec
import pytest

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.analysis.domains import start_domains
from fsw_scheduler.analysis.greedy import greedy_plan
from fsw_scheduler.errors import InputError
from fsw_scheduler.model.levels import (
    lost_charge,
    predicted_levels,
    resource_profiles,
)
from fsw_scheduler.model.plan import Activity, Plan, SolveStatus
from fsw_scheduler.model.problem import Consumable, Resources, encode
from fsw_scheduler.replan.schedule import Schedule, execution_state
from fsw_scheduler.replan.triggers import apply_levels, drift
from fsw_scheduler.runtime.schemas import json_schemas
from fsw_scheduler.solving.solve import solve
from fsw_scheduler.view.timeline import timeline_text
from fsw_scheduler.wire.profiles import plan_profiles

from ..factories import ROOT, make_doc, make_task, problem_from

if TYPE_CHECKING:
    from pathlib import Path


def _doc(
    tasks: list[dict], battery: object, horizon: int = 12, **over: object
) -> dict:
    return make_doc(
        tasks, horizon, {"consumable": {"battery": battery}}, **over
    )


def _plan(*activities: tuple[str, int, int]) -> Plan:
    return Plan(
        SolveStatus.FEASIBLE,
        None,
        tuple(Activity(*a) for a in activities),
    )


#: A charge of 3 x 2 = 6 offered to a battery at 8 of 10: 4 are lost when
#: nothing draws on it meanwhile; then ``use`` takes 4 x 3 = 12, which
#: fits without the capacity (8 + 6) but not with it (10).
CHARGE_THEN_USE = [
    make_task("charge", length=3, uses={"battery": -2}),
    make_task("use", length=4, uses={"battery": 3}),
]


# --------------------------------------------------------------------------
# Model and validation


def test_both_forms_decode_and_read_the_same() -> None:
    """Tests that a number and an object without max mean no capacity."""
    plain = problem_from(_doc([make_task("a")], 8))
    bare = problem_from(_doc([make_task("a")], {"initial": 8}))
    capped = problem_from(_doc([make_task("a")], {"initial": 8, "max": 10}))
    for problem in (plain, bare, capped):
        assert problem.resources.initial_levels == {"battery": 8.0}
        assert problem.resources.initial("battery") == 8.0
    assert plain.resources.ceilings == bare.resources.ceilings == {}
    assert plain.resources.ceiling("battery") is None
    assert capped.resources.ceilings == {"battery": 10.0}
    assert capped.resources.ceiling("battery") == 10.0
    assert capped.resources.consumable["battery"] == Consumable(8, 10)


def test_plain_form_encodes_as_before() -> None:
    """Tests that a problem without capacity encodes byte for byte as
    before (solve records and golden journals hash and compare it)."""
    doc = _doc([make_task("a", uses={"battery": 1})], 8)
    problem = problem_from(doc)
    assert json.loads(encode(problem.resources)) == {
        "consumable": {"battery": 8.0}
    }
    capped = problem_from(_doc([make_task("a")], {"initial": 8, "max": 10}))
    assert json.loads(encode(capped.resources)) == {
        "consumable": {"battery": {"initial": 8.0, "max": 10.0}}
    }


@pytest.mark.parametrize(
    ("battery", "path", "words"),
    [
        (
            {"initial": 12, "max": 10},
            "resources.consumable.battery.initial",
            "initial level 12 is above the capacity max 10",
        ),
        (
            {"initial": -1, "max": 10},
            "resources.consumable.battery.initial",
            ">= 0",
        ),
        (
            {"initial": 0, "max": -1},
            "resources.consumable.battery.max",
            ">= 0",
        ),
        (
            {"max": 10},
            "resources.consumable.battery.initial",
            "missing required field",
        ),
        (
            {"initial": "8"},
            "resources.consumable.battery.initial",
            "got a string",
        ),
        (-1, "resources.consumable.battery", ">= 0"),
    ],
)
def test_capacity_validation_names_the_field(
    battery: object, path: str, words: str
) -> None:
    """Tests each capacity rule with its field path and reason."""
    with pytest.raises(InputError) as info:
        problem_from(_doc([make_task("a")], battery))
    issues = [(i.path, i.reason) for i in info.value.issues]
    assert any(p == path and words in r for p, r in issues), issues


def test_initial_equal_to_max_and_zero_capacity_are_valid() -> None:
    """Tests the edges of the rule: a full store, and an empty one."""
    problem_from(_doc([make_task("a")], {"initial": 10, "max": 10}))
    problem_from(_doc([make_task("a")], {"initial": 0, "max": 0}))


def test_library_api_takes_the_object_form() -> None:
    """Tests solve and check_plan at the package top on a dict with a
    capacity, and Consumable re-exported there."""
    import fsw_scheduler as fs

    doc = json.loads((ROOT / "examples" / "full-battery.json").read_text())
    plan = fs.solve(doc)
    assert plan.starts()["Charge"] == 6
    assert fs.check_plan(doc, plan.to_dict()).ok
    assert fs.Consumable is Consumable


def test_with_levels_keeps_each_form_and_cuts_at_the_capacity() -> None:
    """Tests Resources.with_levels: capacity kept, level cut to it."""
    resources = Resources(
        consumable={"battery": Consumable(8, 10), "fuel": 5.0}
    )
    moved = resources.with_levels({"battery": 12.5, "fuel": 7})
    assert moved.consumable == {"battery": Consumable(10, 10), "fuel": 7}
    assert resources.with_levels({"battery": 3}).initial_levels == {
        "battery": 3,
        "fuel": 5.0,
    }


def test_schema_accepts_both_forms() -> None:
    """Tests the problem schema: a number or an object per consumable."""
    schema = json_schemas()["problem"]
    consumable = schema["$defs"]["Resources"]["properties"]["consumable"]
    kinds = consumable["additionalProperties"]["anyOf"]
    assert {"minimum": 0, "type": "number"} in kinds
    assert {"$ref": "#/$defs/Consumable"} in kinds
    assert schema["$defs"]["Consumable"]["required"] == ["initial"]


# --------------------------------------------------------------------------
# Checker


def test_checker_loses_generation_at_the_capacity() -> None:
    """Tests that a full battery loses charge: without the capacity the
    same plan is valid, with it the level goes below zero."""
    plain = problem_from(_doc(CHARGE_THEN_USE, 8))
    capped = problem_from(_doc(CHARGE_THEN_USE, {"initial": 8, "max": 10}))
    plan = _plan(("charge", 0, 3), ("use", 3, 7))
    assert check_plan(plain, plan).ok
    report = check_plan(capped, plan)
    assert [v.rule for v in report.violations] == ["consumable"]
    assert "capacity 10" in report.violations[0].detail
    # Drawing while charging uses the charge instead of losing it.
    assert check_plan(capped, _plan(("charge", 0, 3), ("use", 0, 4))).ok


def test_checker_nets_the_unit_before_the_capacity() -> None:
    """Tests that use and generation in one unit are netted, then capped:
    a full battery that gives 3 and gets 2 in one unit ends at 9."""
    doc = _doc(
        [
            make_task("gen", length=1, uses={"battery": -2}),
            make_task("take", length=1, uses={"battery": 3}),
            make_task("last", length=1, uses={"battery": 9}),
        ],
        {"initial": 10, "max": 10},
    )
    problem = problem_from(doc)
    assert check_plan(
        problem, _plan(("gen", 0, 1), ("take", 0, 1), ("last", 1, 2))
    ).ok
    assert not check_plan(
        problem, _plan(("gen", 0, 1), ("take", 1, 2), ("last", 2, 3))
    ).ok


# --------------------------------------------------------------------------
# ILP, start plan and domains


@pytest.mark.parametrize("solver", ["cbc", "highs"])
def test_solver_delays_a_charge_so_that_it_is_not_lost(solver: str) -> None:
    """Tests the README scenario: charging at once would fill the battery
    and lose the charge the downlink needs, so the charge waits; without
    the capacity it starts at once."""
    problem = problem_from(
        json.loads((ROOT / "examples" / "full-battery.json").read_text())
    )
    plan = solve(problem, solver)
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.starts() == {"Survey": 0, "Charge": 6, "Downlink": 10}
    assert check_plan(problem, plan).ok
    assert lost_charge(problem, plan)["battery"][9] == 1.0
    plain = problem.replace(resources=Resources(consumable={"battery": 9.0}))
    assert solve(plain, solver).starts()["Charge"] == 0
    # The plan without the capacity loses 3 and leaves the downlink short.
    early = Plan(
        SolveStatus.FEASIBLE,
        None,
        tuple(
            Activity(name, start, start + problem.task(name).length)
            for name, start in solve(plain, solver).starts().items()
        ),
    )
    report = check_plan(problem, early)
    assert [v.rule for v in report.violations] == ["consumable"]
    assert sum(lost_charge(problem, early)["battery"]) == 3.0


def test_level_rows_are_bounded_inequalities() -> None:
    """Tests the ILP rows: L[t] <= max and L[t] <= L[t-1] - net (not =)."""
    from fsw_scheduler.solving.ilp.model import BuiltModel

    tasks = [
        *CHARGE_THEN_USE,
        make_task("more", length=5, uses={"battery": 2}),
    ]
    capped = problem_from(_doc(tasks, {"initial": 8, "max": 10}))
    plain = problem_from(_doc(tasks, 8))
    program = BuiltModel(capped).program
    levels = [c for c, up in enumerate(program.upper) if up == 10.0]
    assert len(levels) == capped.horizon
    senses = {sense for terms, sense, _ in program.rows if levels[0] in terms}
    assert senses == {"L"}
    other = BuiltModel(plain).program
    assert 10.0 not in other.upper


def test_greedy_plans_respect_the_capacity() -> None:
    """Tests that the start plan walks capped levels: its plan is valid,
    and it never counts charge a full battery cannot keep."""
    tasks = [
        make_task("charge", length=3, schedule_cost=0, uses={"battery": -2}),
        make_task(
            "use",
            length=4,
            feasible_interval=[3, 12],
            uses={"battery": 3},
        ),
    ]
    capped = problem_from(_doc(tasks, {"initial": 8, "max": 10}))
    plan = greedy_plan(capped)
    assert plan is not None and check_plan(capped, plan).ok
    assert plan.unscheduled == ("use",)
    plain = problem_from(_doc(tasks, 8))
    plan = greedy_plan(plain)
    assert plan is not None and plan.unscheduled == ()


def test_consumer_bigger_than_the_capacity_gets_no_domain() -> None:
    """Tests the capacity rule of domains.py: 12 needed, 10 held, and the
    only generation cannot overlap it."""
    tasks = [
        make_task(
            "big", length=4, feasible_interval=[6, 12], uses={"battery": 3}
        ),
        make_task(
            "gen", length=3, feasible_interval=[0, 3], uses={"battery": -4}
        ),
    ]
    capped = problem_from(_doc(tasks, {"initial": 10, "max": 10}))
    domain = start_domains(capped)["big"]
    assert domain.empty and domain.cause == "consumable"
    assert "capacity 10" in domain.detail
    plain = problem_from(_doc(tasks, 10))
    assert not start_domains(plain)["big"].empty
    # Generation that can overlap its run counts: the rule keeps it.
    tasks[1]["feasible_interval"] = [0, 12]
    capped = problem_from(_doc(tasks, {"initial": 10, "max": 10}))
    assert not start_domains(capped)["big"].empty
    plan = solve(capped)
    assert plan.starts()["big"] == 6 and check_plan(capped, plan).ok


def test_explanation_names_the_capacity() -> None:
    """Tests the why of a task kept out by charge a full battery loses:
    the charge, all lost, leaves 10 for 12 of mandatory and optional use
    (16 without the capacity)."""
    tasks = [
        make_task(
            "charge",
            length=3,
            schedule_cost=0,
            feasible_interval=[0, 3],
            uses={"battery": -2},
        ),
        make_task(
            "must",
            schedule_cost=0,
            feasible_interval=[3, 12],
            uses={"battery": 3},
        ),
        make_task("may", feasible_interval=[3, 12], uses={"battery": 3}),
    ]
    problem = problem_from(_doc(tasks, {"initial": 10, "max": 10}))
    assert not start_domains(problem)["may"].empty
    plan = solve(problem, explain=True, explain_budget=60.0)
    assert plan.unscheduled == ("may",)
    (why,) = plan.why
    assert why.cause == "consumable"
    assert "initial 10, capacity 10" in why.detail
    assert "would fit if the 10 capacity did not lose" in why.detail
    plain = problem_from(_doc(tasks, 10))
    assert solve(plain).unscheduled == ()


# --------------------------------------------------------------------------
# Replans: predicted and measured levels


def _capped_schedule() -> Schedule:
    problem = problem_from(
        _doc(
            [
                make_task("charge", length=3, uses={"battery": -2}),
                make_task("use", length=2, uses={"battery": 1}),
            ],
            {"initial": 8, "max": 10},
            horizon=20,
        )
    )
    plan = _plan(("charge", 0, 3), ("use", 5, 7))
    assert check_plan(problem, plan).ok
    return Schedule.begin(problem, plan)


def test_predicted_levels_stop_at_the_capacity() -> None:
    """Tests predicted_levels and execution_state under a capacity."""
    schedule = _capped_schedule()
    problem, plan = schedule.problem, schedule.plan
    assert predicted_levels(problem, plan, 1) == {"battery": 10.0}
    assert predicted_levels(problem, plan, 4) == {"battery": 10.0}
    assert predicted_levels(problem, plan, 7) == {"battery": 8.0}
    state = execution_state(problem, plan, 7)
    assert state.levels == {"battery": 8.0}
    measured = execution_state(problem, plan, 7, measured={"battery": 13})
    assert measured.levels == {"battery": 10.0}


def test_replan_carries_capped_levels_and_keeps_the_capacity() -> None:
    """Tests that a replan starts from the capped level, keeps the
    capacity, and cuts a measured level above it."""
    schedule = _capped_schedule()
    replan = apply_levels(schedule, {}, 4)
    assert replan.problem.resources.consumable == {
        "battery": Consumable(10.0, 10.0)
    }
    measured = apply_levels(schedule, {"battery": 12.0}, 4)
    assert measured.problem.resources.initial_levels == {"battery": 10.0}
    # Measured at 1 (9), carried to 4 through the charge: full again.
    earlier = apply_levels(schedule, {"battery": 5.0}, 4, at=1)
    assert earlier.problem.resources.initial_levels == {"battery": 9.0}
    # A battery reported above its capacity is full, not drifting.
    assert drift(schedule.problem, schedule.plan, 4, {"battery": 10.4}) == []


# --------------------------------------------------------------------------
# Profiles and pictures


def test_profiles_and_text_show_the_capacity_and_the_loss() -> None:
    """Tests resource_profiles, lost_charge, plan_profiles and the text."""
    problem = problem_from(_doc(CHARGE_THEN_USE, {"initial": 8, "max": 10}))
    plan = _plan(("charge", 0, 3), ("use", 3, 7))
    levels = resource_profiles(problem, plan)["battery"]
    assert levels[:8] == [10, 10, 10, 7, 4, 1, -2, -2]
    assert lost_charge(problem, plan) == {
        "battery": [0, 2, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0]
    }
    from fsw_scheduler.wire.messages import PlanMessage

    message = msgspec.convert(
        {
            "plan_id": 1,
            "issued_at": 0,
            "horizon_start": 0,
            "horizon_end": 12,
            "status": "feasible",
            "objective": None,
            "activities": [
                {"task": a.task, "start": a.start, "end": a.end}
                for a in plan.activities
            ],
        },
        PlanMessage,
    )
    profiles = plan_profiles(problem, message)
    assert profiles.capacities == {"battery": 10.0}
    assert profiles.levels["battery"][:4] == (8.0, 10.0, 10.0, 10.0)
    plain = problem_from(_doc(CHARGE_THEN_USE, 8))
    encoded = msgspec.json.encode(plan_profiles(plain, message))
    assert b"capacities" not in encoded
    assert "capacity 10, lost 4" in timeline_text(problem, plan)


def test_session_levels_draw_the_capacity(tmp_path: Path) -> None:
    """Tests levels.png of a session whose battery has a capacity."""
    pytest.importorskip("matplotlib")
    from fsw_scheduler.view.session import Session, draw_levels
    from fsw_scheduler.wire.messages import PlanMessage

    problem = problem_from(_doc(CHARGE_THEN_USE, {"initial": 8, "max": 10}))
    plan = msgspec.convert(
        {
            "plan_id": 1,
            "issued_at": 0,
            "horizon_start": 0,
            "horizon_end": 12,
            "status": "feasible",
            "objective": None,
            "activities": [{"task": "charge", "start": 0, "end": 3}],
        },
        PlanMessage,
    )
    session = Session(
        initial=problem,
        plans=[plan],
        problems={1: problem},
        measured={"battery": [(2, 10.0), (4, 9.5)]},
    )
    target = draw_levels(session, tmp_path / "levels.png")
    assert target.read_bytes().startswith(b"\x89PNG")


def test_gantt_draws_the_capacity(tmp_path: Path) -> None:
    """Tests that a plan with a full battery draws (capacity, loss)."""
    pytest.importorskip("matplotlib")
    from fsw_scheduler.view.gantt import gantt

    problem = problem_from(_doc(CHARGE_THEN_USE, {"initial": 8, "max": 10}))
    (target,) = gantt(
        problem,
        _plan(("charge", 0, 3), ("use", 3, 7)),
        tmp_path / "plan.png",
        measured={"battery": [(2, 10.0), (5, 4.0)]},
    )
    assert target.stat().st_size > 0


def test_engine_keeps_the_capacity_through_a_drift_replan() -> None:
    """Tests the engine on the full-battery scenario: a level reported
    above the capacity is full (no replan); a low one replans from it,
    with the capacity kept."""
    from fsw_scheduler.engine.events import StartSolve

    from ..engine.driver import Driver, statuses

    problem = problem_from(
        json.loads((ROOT / "examples" / "full-battery.json").read_text())
    )
    driver = Driver(problem)
    driver.tick(0)
    for now in range(1, 11):
        driver.tick(now)
    schedule = driver.engine.schedule
    assert schedule is not None
    assert predicted_levels(schedule.problem, schedule.plan, 10) == {
        "battery": 10.0
    }
    out = driver.level("battery", 10.4, 10)
    assert not [c for c in out if isinstance(c, StartSolve)]
    assert not statuses(out, "drift")
    out = driver.level("battery", 8.0, 10)
    assert statuses(out, "drift")
    assert driver.plan.plan_id == 2
    schedule = driver.engine.schedule
    assert schedule is not None
    assert schedule.problem.resources.consumable == {
        "battery": Consumable(8.0, 10.0)
    }
    assert check_plan(schedule.problem, schedule.plan).ok
