"""Tests of late completions: what waits for an activity past its end."""

from __future__ import annotations

import json
import random
from dataclasses import dataclass, field

import pytest

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.events import (
    Command,
    Log,
    ReportArrived,
    StartSolve,
)
from fsw_scheduler.model.problem import Problem, decode_problem
from fsw_scheduler.wire import messages

from .driver import Driver, encoded, published, statuses


@dataclass
class Flight:
    """What an executor saw and did: each run of an activity (a task may
    run again: a tight chain redone; one still running at the end ends
    there), each start, the solves asked for, and every command."""

    runs: list[tuple[str, int, int]] = field(default_factory=list)
    begun: list[tuple[str, int]] = field(default_factory=list)
    commands: list[Command] = field(default_factory=list)
    still_running: int = 0

    @property
    def started(self) -> dict[str, int]:
        """When each task's first run started."""
        out: dict[str, int] = {}
        for task, start in self.begun:
            out.setdefault(task, start)
        return out

    @property
    def ended(self) -> dict[str, int]:
        """When each task's first run ended (reported ``completed``)."""
        out: dict[str, int] = {}
        for task, _, end in self.completed:
            out.setdefault(task, end)
        return out

    @property
    def completed(self) -> list[tuple[str, int, int]]:
        """The runs that reported ``completed``."""
        return self.runs[: len(self.runs) - self.still_running]

    def solves(self, trigger: str) -> list[StartSolve]:
        """The solves asked for with ``trigger``."""
        return [
            c
            for c in self.commands
            if isinstance(c, StartSolve) and c.trigger == trigger
        ]


def fly(
    driver: Driver,
    until: int,
    ends: dict[str, int],
    *,
    ahead: dict[str, int] | None = None,
) -> Flight:
    """Tick ``driver`` from 0 to ``until`` with an executor that starts
    each dispatch when it arrives and reports ``completed`` at the end of
    its dispatch, or, for its first run, at ``ends[task]`` (an overrun),
    after the clock message of that unit (the report races the clock and
    loses). ``ahead``: tasks whose completion is sent one unit early,
    held by the node until the clock reaches it."""
    flight = Flight()
    planned: dict[str, tuple[int, int]] = {}
    ran: set[str] = set()
    for now in range(until + 1):
        out = driver.tick(now)
        seen = 0
        while True:
            for message in published(out[seen:], messages.Dispatch):
                if message.action == "cancel":
                    planned.pop(message.task, None)
                    continue
                end = now + message.end - message.start
                if message.task not in ran:
                    end = ends.get(message.task, end)
                ran.add(message.task)
                planned[message.task] = (now, end)
                flight.begun.append((message.task, now))
            seen = len(out)
            more: list[Command] = []
            for task, (start, end) in sorted(planned.items()):
                early = (ahead or {}).get(task)
                if end == now or (early is not None and end == now + early):
                    del planned[task]
                    flight.runs.append((task, start, end))
                    report = messages.ActivityReport(task, "completed", end)
                    more += driver.step(ReportArrived(report))
            if not more:
                break
            out += more
        flight.commands += out
    flight.runs += [(t, s, until + 1) for t, (s, _) in sorted(planned.items())]
    flight.still_running = len(planned)
    return flight


def _paper(mode: str, report_ahead: int = 0) -> Driver:
    config = EngineConfig(late_completion=mode, report_ahead=report_ahead)
    return Driver(config=config)


def test_today_a_tight_successor_runs_while_its_predecessor_overruns() -> None:
    """Tests that with ``late-completion`` off (the paper's clock-driven
    flight) an overrun of SetPositionK [6, 7) until 9 does not stop its
    tight successor BatteryCharge: commanded at 7 while SetPositionK
    still runs, on the position both use, and no replan follows."""
    flight = fly(_paper("off"), 10, {"SetPositionK": 9})
    assert flight.started["BatteryCharge"] == 7 < flight.ended["SetPositionK"]
    assert not flight.solves("overrun")
    assert not flight.solves("late_completion")


def test_an_overrun_holds_the_tight_successor_and_moves_it() -> None:
    """Tests that with ``push`` the tight successor of SetPositionK,
    which runs until 9 instead of 7, is not commanded while it runs: held
    at 7 (its start), one ``overrun`` replan at 8 (its start passed)
    takes SetPositionK as running on and moves BatteryCharge to 9, where
    it is commanded right after the completion; the status says it was
    held, and the tight chain after it moved by 2."""
    driver = _paper("push")
    flight = fly(driver, 12, {"SetPositionK": 9})
    assert flight.started["BatteryCharge"] == 9 == flight.ended["SetPositionK"]
    (solve,) = flight.solves("overrun")
    assert solve.problem.start == 8
    held = statuses(flight.commands, "activity_held")
    assert [s.detail.split(" ")[0] for s in held] == ["BatteryCharge"]
    assert "follows SetPositionK (tight)" in held[0].detail
    plans = published(flight.commands, messages.PlanMessage)
    assert [p.trigger for p in plans] == ["initial", "overrun"]
    starts = {a.task: a.start for a in plans[-1].activities}
    assert starts["BatteryCharge"] == 9
    assert starts["SetPositionZ"] == 19  # was 17: the chain moved by 2
    # The late completion lands where the overrun plan put the end.
    assert not flight.solves("late_completion")
    last = driver.engine.status().last_solve
    assert last is not None and last.trigger == "overrun"


def test_a_late_completion_before_the_assumed_end_pulls_back() -> None:
    """Tests on the paper that SetPositionK, completing at 8 (1 unit late)
    just after the ``overrun`` replan of that unit took it to run until
    9, replans at once (``late_completion``): BatteryCharge, pushed to 9,
    comes back to 8 and is commanded there, and the tight chain after it
    keeps its new places from there."""
    driver = _paper("push")
    flight = fly(driver, 10, {"SetPositionK": 8})
    plans = published(flight.commands, messages.PlanMessage)
    assert [p.trigger for p in plans] == [
        "initial",
        "overrun",
        "late_completion",
    ]
    assert {a.task: a.start for a in plans[1].activities}["BatteryCharge"] == 9
    assert {a.task: a.start for a in plans[2].activities}["BatteryCharge"] == 8
    assert flight.started["BatteryCharge"] == 8
    logs = [c.text for c in flight.commands if isinstance(c, Log)]
    assert any(
        "SetPositionK completed at 8, 1 unit after the end of its dispatch "
        "(7); the plan took it to run until 9" in text
        for text in logs
    )


def test_a_completion_racing_the_clock_replans_nothing() -> None:
    """Tests that a completion at the planned end that reaches the node
    after that unit's clock message (or one unit early, held until the
    clock reaches it) releases the successor in the same unit: it is
    commanded on time, not late, and nothing is replanned."""
    for ahead in (None, {"SetPositionK": 1}):
        driver = _paper("push", report_ahead=1)
        flight = fly(driver, 9, {}, ahead=ahead)
        assert flight.started["BatteryCharge"] == 7
        dispatch = next(
            m
            for m in published(flight.commands, messages.Dispatch)
            if m.task == "BatteryCharge"
        )
        assert not dispatch.late
        assert not [c for c in flight.commands if isinstance(c, StartSolve)][
            1:
        ]
        assert not statuses(flight.commands, "activity_held")


def _arm_problem() -> Problem:
    """Scan [0, 4) on the arm; Store lax after it; Stow waits for the
    arm; Beacon on its own at 6."""
    task = {"delay_cost": 1, "schedule_cost": 2}
    return decode_problem(
        json.dumps(
            {
                "horizon": 40,
                "resources": {"binary": ["arm", "radio"]},
                "tasks": [
                    {
                        "id": "Scan",
                        "length": 4,
                        "delay_cost": 5,
                        "schedule_cost": 0,
                        "uses": {"arm": 1},
                    },
                    {"id": "Store", "length": 2, **task},
                    {"id": "Stow", "length": 2, **task, "uses": {"arm": 1}},
                    {
                        "id": "Beacon",
                        "length": 1,
                        **task,
                        "feasible_interval": [6, 6],
                        "uses": {"radio": 1},
                    },
                ],
                "precedences": [
                    {"before": "Scan", "after": "Store", "kind": "lax"}
                ],
                "feasible_interval_applies_to": "start",
            }
        )
    )


def test_a_slow_executor_costs_a_few_replans_not_one_per_unit() -> None:
    """Tests that an activity running 10 units past its end holds its
    lax successor and the task waiting for its binary resource until it
    completes, that the overrun replans grow apart (3 of them, not 10),
    that the completion, earlier than the last overrun plan assumed,
    replans at once (``late_completion``) and starts both at 14, and
    that an independent activity keeps its time."""
    driver = Driver(_arm_problem(), EngineConfig(late_completion="push"))
    flight = fly(driver, 20, {"Scan": 14})
    assert flight.started["Store"] == 14
    assert flight.started["Stow"] in (14, 16)
    assert flight.started["Beacon"] == 6
    assert [s.problem.start for s in flight.solves("overrun")] == [5, 7, 11]
    (late,) = flight.solves("late_completion")
    assert late.problem.start == 14
    logs = [c.text for c in flight.commands if isinstance(c, Log)]
    assert any("Scan completed at 14, 10 units after" in t for t in logs)


def test_the_same_overrun_gives_the_same_commands() -> None:
    """Tests that an overrun flown twice gives the same commands (the
    rules are deterministic; replay relies on it)."""
    runs = [
        encoded(fly(_paper("push"), 11, {"SetPositionK": 9}).commands)
        for _ in range(2)
    ]
    assert runs[0] == runs[1]


def _generated(seed: int) -> Problem:
    """A chain-and-resource problem drawn from ``seed``: 8 tasks on two
    binary resources and a multiple one, with precedences of every kind
    between consecutive tasks of a chain."""
    rng = random.Random(seed)
    tasks = []
    for idx in range(8):
        uses: dict[str, float] = {"power": rng.choice([2, 3, 5])}
        uses[rng.choice(["arm", "radio"])] = 1
        tasks.append(
            {
                "id": f"T{idx}",
                "length": rng.randint(1, 4),
                "delay_cost": rng.randint(1, 5),
                "schedule_cost": rng.randint(1, 5),
                "uses": uses,
            }
        )
    precedences = [
        {
            "before": f"T{idx}",
            "after": f"T{idx + 1}",
            "kind": rng.choice(["tight", "lax"]),
            "scope": rng.choice(["both", "at_least_first"]),
            "offset": rng.randint(0, 1),
        }
        for idx in range(0, 7, 2)
    ]
    return decode_problem(
        json.dumps(
            {
                "horizon": 60,
                "resources": {
                    "binary": ["arm", "radio"],
                    "multiple": {"power": 6},
                },
                "tasks": tasks,
                "precedences": precedences,
            }
        )
    )


@pytest.mark.parametrize("lead", [0, 1])
@pytest.mark.parametrize("seed", range(1, 9))
def test_generated_overruns_never_break_precedence_or_resource(
    seed: int, lead: int
) -> None:
    """Tests on generated problems that, whichever planned activity runs
    1 to 6 units past its end, nothing is started before a predecessor
    has ended (+ offset), no binary resource has two activities at once
    and the multiple one is never overfilled, as flown by the executor,
    and the late activity's successors still run; with a replan lead of
    0 (the bus clock) and 1 (the wall clock's default)."""
    problem = _generated(seed)
    config = EngineConfig(late_completion="push", replan_lead=lead)
    first = Driver(problem, config)
    first.tick(0)
    rng = random.Random(seed)
    victim = rng.choice(first.plan.activities)
    late = victim.end + rng.randint(1, 6)
    flight = fly(Driver(problem, config), 70, {victim.task: late})
    assert flight.ended[victim.task] == late
    uses = {t.id: t.uses for t in problem.tasks}
    for task, start, _ in flight.runs:
        # No run starts before the last run of a predecessor that started
        # before it has ended (+ offset).
        for prec in problem.precedences:
            ends = [
                e for t, s, e in flight.runs if t == prec.before and s < start
            ]
            if prec.after == task and ends:
                assert start >= max(ends) + prec.offset, (prec, flight.runs)
    for unit in range(70):
        active = [t for t, s, e in flight.runs if s <= unit < e]
        for name in ("arm", "radio"):
            assert sum(uses[t].get(name, 0) for t in active) <= 1, unit
        assert sum(uses[t].get("power", 0) for t in active) <= 6, unit
    for prec in problem.precedences:
        for task, start, _ in flight.runs:
            if prec.before == victim.task and task == prec.after:
                assert start >= late + prec.offset, (prec, flight.runs)


def test_a_held_activity_waits_for_the_replan_under_way() -> None:
    """Tests with a slow solver that when SetPositionK completes at 8 (1
    unit late) while the ``overrun`` replan of that unit is still
    solving, its tight successor BatteryCharge, due since 7, is not
    commanded late under the old plan: it waits for the replans (the
    overrun's, then the ``late_completion`` the report queued) and is
    commanded at 8, where the last one puts it."""
    driver = Driver(config=EngineConfig(late_completion="push"), hold=True)
    driver.tick(0)
    driver.finish()
    ends = {"SetHFOption": 1, "SetPositionX": 1, "DownlinkSat2Sat": 6}
    for now in range(1, 8):
        driver.tick(now)
        for task, end in ends.items():
            if end == now:
                driver.report(task, "completed", now)
    assert driver.engine.plan_id == 1
    driver.tick(8)
    (overrun,) = driver.held
    assert overrun.trigger == "overrun"
    out = driver.report("SetPositionK", "completed", 8)
    assert not published(out, messages.Dispatch)
    out = driver.finish()
    assert driver.plan.trigger == "overrun"
    assert not published(out, messages.Dispatch)
    (late,) = driver.held
    assert late.trigger == "late_completion"
    out = driver.finish()
    (dispatch,) = published(out, messages.Dispatch)
    assert (dispatch.task, dispatch.start, dispatch.late) == (
        "BatteryCharge",
        8,
        False,
    )


def test_an_early_completion_during_a_solve_still_pulls_forward() -> None:
    """Tests with a slow solver that DownlinkSat2Sat completing at 3 (3
    units early, gain 2) while a goal's solve is in flight is carried
    into that solve's plan: the early_completion replan queued behind it
    takes it as finished and pulls SetPositionK from 6 to 3."""
    from .driver import small_goal

    driver = Driver(config=EngineConfig(early_completion_gain=2), hold=True)
    driver.tick(0)
    driver.finish()
    driver.tick(1)
    for task in ("SetHFOption", "SetPositionX"):
        driver.report(task, "completed", 1)
    driver.tick(2)
    driver.goal(small_goal("g1", "Ping"), 2)
    driver.tick(3)
    driver.report("DownlinkSat2Sat", "completed", 3)
    driver.finish()
    assert driver.plan.trigger == "goal"
    assert [c.trigger for c in driver.held] == ["early_completion"]
    out = driver.finish()
    starts = {a.task: a.start for a in driver.plan.activities}
    assert driver.plan.trigger == "early_completion"
    assert starts["SetPositionK"] == 3
    assert "DownlinkSat2Sat" not in starts
    (dispatch,) = published(out, messages.Dispatch)
    assert (dispatch.task, dispatch.start) == ("SetPositionK", 3)
