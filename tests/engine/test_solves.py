"""Tests of the replanner's predictable replans: the commit window, the
moves each plan reports, and the degraded path that breaks pins."""

from __future__ import annotations

import json

import msgspec
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.events import StartSolve
from fsw_scheduler.model.plan import Moved, SolveStatus
from fsw_scheduler.wire import messages

from ..factories import make_doc, make_task, problem_from
from .driver import Driver, paper_goal, published, small_goal, statuses


def _paper_at_15(config: EngineConfig) -> Driver:
    """The paper session, ticked unit by unit to 15, then the Table 2
    goal (its replan over [15, 65))."""
    driver = Driver(config=config)
    for now in range(16):
        driver.tick(now)
    driver.goal(paper_goal())
    return driver


def _moved(plan: messages.PlanMessage) -> tuple[Moved, ...]:
    """The moves of a plan from a node that reports them."""
    assert not isinstance(plan.moved, msgspec.UnsetType), "moves unreported"
    return plan.moved


def test_defaults_report_no_moves_and_plan_as_the_paper() -> None:
    """Tests that with the default settings the Table 2 replan is the
    paper's (SetPositionY and the downlink pulled to 33 and 34) and its
    plan and status carry no ``moved`` (byte-identical to before)."""
    driver = _paper_at_15(EngineConfig())
    starts = {a.task: a.start for a in driver.plan.activities}
    assert starts["SetPositionY"] == 33
    assert starts["DownlinkSat2Ground"] == 34
    assert b'"moved"' not in messages.encode(driver.plan)
    assert b'"moved"' not in messages.encode(driver.engine.status())


def test_moves_are_reported_with_a_commit_window() -> None:
    """Tests that a plan says what it moved (from, to) and the status
    counts it, when the window does not reach the moved activities."""
    driver = _paper_at_15(EngineConfig(commit_window=10))
    plan = driver.plan
    assert [(m.task, m.from_, m.to) for m in _moved(plan)] == [
        ("SetPositionY", 38, 33),
        ("DownlinkSat2Ground", 39, 34),
    ]
    encoded = json.loads(messages.encode(plan))
    first = encoded["moved"][0]
    assert (first["task"], first["from"], first["to"]) == (
        "SetPositionY",
        38,
        33,
    )
    # Both moved together: back at 38 and 39 nothing breaks, the delay
    # saved is the reason (no stability term prices the move).
    assert first["why"].startswith("38 is still free")
    status = driver.engine.status()
    assert status.last_solve is not None and status.last_solve.moved == 2


def test_commit_window_keeps_planned_starts() -> None:
    """Tests that a window of 25 units at t=15 pins SetPositionY (38) and
    the downlink (39): the goal's replan keeps them, moves nothing, and
    the new SetPositionZ (a goal task reusing an obsoleted id) is not
    pinned at the old one's start."""
    driver = _paper_at_15(EngineConfig(commit_window=25))
    goal_solve = [
        c
        for c in driver.history
        if isinstance(c, StartSolve) and c.trigger == "goal"
    ][-1]
    pinned = {t.id: t.fixed_start for t in goal_solve.problem.tasks}
    assert pinned["SetPositionY"] == 38
    assert pinned["DownlinkSat2Ground"] == 39
    assert pinned["SetPositionZ"] is None
    starts = {a.task: a.start for a in driver.plan.activities}
    assert starts["SetPositionY"] == 38
    assert starts["DownlinkSat2Ground"] == 39
    assert driver.plan.moved == ()
    assert driver.plan.status is SolveStatus.OPTIMAL
    last_solve = driver.engine.status().last_solve
    assert last_solve is not None and last_solve.moved == 0


def _antenna_problem() -> dict:
    """A pass on the antenna planned at 5, and room for nothing else."""
    return make_doc(
        [make_task("Pass", 3, schedule_cost=2, uses={"antenna": 1})],
        horizon=20,
        resources={"binary": ["antenna"]},
    )


def _urgent(goal_id: str = "urgent", *, mandatory: bool = True) -> dict:
    """A goal whose task needs the antenna over [3, 7): Pass's slot."""
    return {
        "goal_id": goal_id,
        "tasks": [
            make_task(
                "Urgent",
                4,
                schedule_cost=0 if mandatory else 1,
                uses={"antenna": 1},
                feasible_interval=[3, 7],
            )
        ],
    }


def _pass_at_5(config: EngineConfig) -> Driver:
    doc = _antenna_problem()
    doc["tasks"][0]["feasible_interval"] = [5, 8]
    driver = Driver(problem_from(doc), config=config)
    driver.tick(0)
    driver.tick(1)
    assert driver.plan.activities[0].start == 5
    return driver


def test_pins_that_leave_no_plan_are_broken_and_named() -> None:
    """Tests the degraded path: a mandatory goal task that only fits over
    the pinned Pass makes the pinned problem infeasible; the replan is
    solved without the pins, the plan is ``degraded``, its ``why`` names
    the pin broken and the alarm status says so; the goal is accepted."""
    driver = _pass_at_5(EngineConfig(commit_window=10))
    out = driver.goal(_urgent())
    plan = driver.plan
    assert plan.status is SolveStatus.DEGRADED
    assert [a.task for a in plan.activities] == ["Urgent"]
    assert plan.unscheduled == ("Pass",)
    (pin,) = [b for b in plan.why if b.cause == "commit_window"]
    assert pin.task == "Pass" and "planned at 5" in pin.detail
    (alarm,) = statuses(out, "alarm")
    assert "Pass pin broken" in alarm.detail
    assert statuses(out, "goal_accepted")
    solves = [c for c in out if isinstance(c, StartSolve)]
    assert [
        dict((t.id, t.fixed_start) for t in s.problem.tasks) for s in solves
    ] == [
        {"Pass": 5, "Urgent": None},
        {"Pass": None, "Urgent": None},
    ]


def test_optional_goal_tasks_left_out_by_pins_are_the_window_working() -> None:
    """Tests that an optional goal task that would need a pinned slot is
    left out, the pin kept, and nothing is degraded."""
    driver = _pass_at_5(EngineConfig(commit_window=10))
    out = driver.goal(_urgent(mandatory=False))
    plan = driver.plan
    assert plan.status is SolveStatus.OPTIMAL
    assert plan.activities[0].task == "Pass"
    assert plan.activities[0].start == 5
    assert plan.unscheduled == ("Urgent",)
    assert not statuses(out, "alarm")


def test_without_a_window_the_urgent_task_takes_the_slot() -> None:
    """Tests the same goal with no window: Pass is moved or dropped
    freely, the plan is not degraded (the contrast of the test above)."""
    driver = _pass_at_5(EngineConfig())
    out = driver.goal(_urgent())
    assert driver.plan.status is SolveStatus.OPTIMAL
    assert not statuses(out, "alarm")
    assert len([c for c in out if isinstance(c, StartSolve)]) == 1


# -- property: nothing in the window moves but through the degraded path --

_goal_specs = st.lists(
    st.tuples(
        st.integers(1, 3),  # units until the goal
        st.integers(1, 4),  # length
        st.sampled_from([0, 1, 3, 5]),  # schedule cost
        st.booleans(),  # uses the antenna
    ),
    min_size=1,
    max_size=4,
)


@settings(
    max_examples=25,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(_goal_specs, st.integers(1, 8))
def test_inside_the_window_nothing_moves_but_when_degraded(
    specs: list[tuple[int, int, int, bool]], window: int
) -> None:
    """Tests on generated sessions that every activity planned (and not
    dispatched) inside ``[now, now + window)`` keeps its start in the next
    plan, unless that plan is degraded and names it as a broken pin."""
    doc = make_doc(
        [
            make_task(f"t{i}", 2 + i % 2, uses={"antenna": 1} if i % 2 else {})
            for i in range(4)
        ],
        horizon=30,
        resources={"binary": ["antenna"]},
    )
    driver = Driver(
        problem_from(doc), config=EngineConfig(commit_window=window)
    )
    now = 0
    driver.tick(now)
    for serial, (wait, length, cost, antenna) in enumerate(specs):
        now += wait
        driver.tick(now)
        before = driver.plan
        lifecycle = driver.engine.status().activities
        goal = small_goal(f"g{serial}", f"n{serial}")
        task = goal["tasks"][0]
        task.update(length=length, schedule_cost=cost)
        task["uses"] = {"antenna": 1} if antenna else {}
        driver.goal(goal)
        after = driver.plan
        if after.plan_id == before.plan_id:
            continue  # rejected: nothing changed
        starts = {a.task: a.start for a in after.activities}
        broken = {b.task for b in after.why if b.cause == "commit_window"}
        for act in before.activities:
            if lifecycle.get(act.task) != "planned":
                continue
            if not now <= act.start < now + window:
                continue
            if act.task in broken:
                assert after.status is SolveStatus.DEGRADED
                continue
            assert starts.get(act.task) == act.start, (
                f"{act.task} planned at {act.start} moved to "
                f"{starts.get(act.task)} within [{now}, {now + window})"
            )
        moved = {m.task: (m.from_, m.to) for m in _moved(after)}
        for name, (old, new) in moved.items():
            assert starts[name] == new and old != new
    assert (
        msgspec.json.decode(messages.encode(driver.plan))["moved"] is not None
    )
    assert published(driver.history, messages.PlanMessage)


# -- stability --------------------------------------------------------------


def test_lexicographic_keeps_the_paper_plan_where_it_can() -> None:
    """Tests the Table 2 replan under ``lexicographic``: SetPositionY and
    the downlink stay at 38 and 39 (nothing moves, the unscheduled cost
    is the paper's), the objective reports ``moves`` 0; under ``moves``
    at 5 each, pulling both forward by 5 units saves more delay than it
    costs, so they move and the objective says so."""
    lex = _paper_at_15(EngineConfig(stability="lexicographic"))
    starts = {a.task: a.start for a in lex.plan.activities}
    assert (starts["SetPositionY"], starts["DownlinkSat2Ground"]) == (38, 39)
    assert lex.plan.moved == ()
    assert lex.plan.objective is not None
    assert lex.plan.objective.moves == 0
    paper = _paper_at_15(EngineConfig())
    assert paper.plan.objective is not None
    assert (
        lex.plan.objective.unscheduled_cost
        == paper.plan.objective.unscheduled_cost
    )
    moves = _paper_at_15(EngineConfig(stability="moves", move_cost=5))
    assert moves.plan.objective is not None
    assert moves.plan.objective.move_cost == 5
    assert moves.plan.objective.moves == len(_moved(moves.plan)) == 2


def _restricted_unscheduled(command: StartSolve, previous: dict) -> int:
    """The least unscheduled cost of ``command``'s problem when each
    previously planned task may only keep its start or be left out."""
    from fsw_scheduler.runtime.policy import run_solve

    from .driver import SOLVE_CONFIG

    problem = command.problem
    tasks = []
    for task in problem.tasks:
        was = previous.get(task.id)
        if was is not None and task.fixed_start is None:
            task = msgspec.structs.replace(
                task,
                feasible_interval=(was, was),
                feasible_interval_applies_to="start",
            )
        tasks.append(task)
    plan = run_solve(
        SOLVE_CONFIG,
        StartSolve(0, "check", problem.replace(tasks=tuple(tasks))),
    )
    assert plan.objective is not None  # left-out tasks keep it feasible
    return plan.objective.unscheduled_cost


@settings(
    max_examples=20,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(_goal_specs)
def test_lexicographic_moves_only_when_the_unscheduled_cost_needs_it(
    specs: list[tuple[int, int, int, bool]],
) -> None:
    """Tests on generated sessions under ``lexicographic``: a replan that
    moves a previously planned activity does so only because keeping
    every one at its start (or leaving it out) would cost more
    unscheduled cost; otherwise nothing moves."""
    doc = make_doc(
        [
            make_task(f"t{i}", 2 + i % 2, uses={"antenna": 1} if i % 2 else {})
            for i in range(4)
        ],
        horizon=30,
        resources={"binary": ["antenna"]},
    )
    config = EngineConfig(stability="lexicographic")
    driver = Driver(problem_from(doc), config=config)
    now = 0
    driver.tick(now)
    for serial, (wait, length, cost, antenna) in enumerate(specs):
        now += wait
        driver.tick(now)
        before = driver.plan.plan_id
        goal = small_goal(f"g{serial}", f"n{serial}")
        task = goal["tasks"][0]
        task.update(length=length, schedule_cost=cost)
        task["uses"] = {"antenna": 1} if antenna else {}
        out = driver.goal(goal)
        if driver.plan.plan_id == before:
            continue
        (command,) = [c for c in out if isinstance(c, StartSolve)]
        plan = driver.plan
        assert plan.objective is not None
        assert plan.objective.moves == len(_moved(plan))
        needed = _restricted_unscheduled(command, command.previous)
        if plan.moved:
            assert needed > plan.objective.unscheduled_cost, plan.moved
        else:
            assert needed >= plan.objective.unscheduled_cost
