"""Drive an engine as the node does, without a bus: events in, commands out.

:class:`Driver` runs each solve the engine asks for with the node's real
solve (CBC), so these tests exercise everything but Zenoh. Nothing here
imports the bus.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any, Literal, TypeVar

import msgspec

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.core import Engine
from fsw_scheduler.engine.events import (
    Command,
    Event,
    ForecastArrived,
    GoalArrived,
    LevelArrived,
    Publish,
    ReportArrived,
    SolveDone,
    StartSolve,
    Tick,
)
from fsw_scheduler.model.goal import decode_goal
from fsw_scheduler.runtime.config import NodeConfig
from fsw_scheduler.runtime.policy import run_solve
from fsw_scheduler.wire import messages

from ..factories import DATA, problem_from

#: What an activity report may say (``ActivityReport.state``).
ReportState = Literal["running", "completed", "failed", "cancelled"]

if TYPE_CHECKING:
    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.model.problem import Problem

#: The node's settings in tests: explanations off (no extra solves), 30 s
#: per solve and 60 s for the explanation a shedding solve still asks
#: for, so that a slow machine changes timings, not plans (with the 2 s
#: default, a loaded machine ran out of explanation time: other ``why``).
SOLVE_CONFIG = NodeConfig(
    clock="bus",
    heartbeat=0,
    explain=False,
    time_limit=30.0,
    explain_budget=60.0,
    clock_stall=None,
)


def paper_goal() -> dict[str, Any]:
    """The paper's Table 2 goal (``monitor-target-lf``) as a dict."""
    return json.loads((DATA / "paper_table2_goal.json").read_text())


M = TypeVar("M", bound=msgspec.Struct)

#: Plans already computed, by exact solver input: the solver is pinned
#: (one thread, fixed seed), so reusing them only saves time.
_SOLVED: dict[bytes, Plan] = {}


def solve(
    command: StartSolve,
    *,
    cache: bool = True,
    config: NodeConfig = SOLVE_CONFIG,
) -> Plan:
    """Run the node's real solve for ``command`` (with ``config``: the
    node's settings, whose stability decides the move term)."""
    key = msgspec.json.encode(
        (
            command.problem,
            command.warm,
            command.previous,
            config.stability,
            config.move_cost,
        )
    )
    if cache and key in _SOLVED:
        return _SOLVED[key]
    plan = run_solve(config, command)
    _SOLVED[key] = plan
    return plan


class Driver:
    """Feeds events to an engine and runs its solves like the node does.

    With ``hold=True`` solves are kept in :attr:`held` until
    :meth:`finish` runs them, which stands for a slow solver.
    """

    def __init__(
        self,
        problem: Problem | None = None,
        config: EngineConfig | None = None,
        *,
        hold: bool = False,
        cache: bool = True,
    ) -> None:
        self.engine = Engine(config or EngineConfig(), problem or paper())
        self.hold = hold
        self.cache = cache
        self.held: list[StartSolve] = []
        self.history: list[Command] = []
        self.now = 0

    def step(self, event: Event, now: int | None = None) -> list[Command]:
        """One engine step, then any solve it started (unless held)."""
        if now is not None:
            self.now = now
        out = self.engine.step(event, self.now)
        self.history += out
        result = list(out)
        for command in out:
            if isinstance(command, StartSolve):
                if self.hold:
                    self.held.append(command)
                else:
                    result += self.finish(command)
        return result

    def finish(self, command: StartSolve | None = None) -> list[Command]:
        """Solve ``command`` (default: the oldest held one), feed back."""
        if command is None:
            command = self.held.pop(0)
        engine = self.engine.config
        config = SOLVE_CONFIG.replace(
            stability=engine.stability, move_cost=engine.move_cost
        )
        plan = solve(command, cache=self.cache, config=config)
        return self.step(SolveDone(command.solve_id, plan))

    def tick(self, now: int) -> list[Command]:
        """The clock reached ``now``."""
        return self.step(Tick(now), now)

    def goal(self, doc: dict, now: int | None = None) -> list[Command]:
        """A decoded goal arrives."""
        return self.step(GoalArrived(decode_goal(json.dumps(doc))), now)

    def report(self, task: str, state: ReportState, at: int) -> list[Command]:
        """An execution report arrives."""
        report = messages.ActivityReport(task, state, at)
        return self.step(ReportArrived(report))

    def level(self, resource: str, level: float, at: int) -> list[Command]:
        """A measured level arrives."""
        reading = messages.ResourceLevel(resource, level, at)
        return self.step(LevelArrived(reading))

    def forecast(
        self, resource: str, at: int, **profile: Any
    ) -> list[Command]:
        """A forecast arrives, read strictly as the node reads it."""
        payload = json.dumps({"resource": resource, "at": at, **profile})
        forecast = messages.decode_input("resource_forecast", payload.encode())
        return self.step(ForecastArrived(forecast))

    @property
    def plan(self) -> messages.PlanMessage:
        """The engine's current plan."""
        plan = self.engine.plan_message
        assert plan is not None
        return plan


def paper() -> Problem:
    """The paper's Table 1 problem."""
    return problem_from(json.loads((DATA / "paper_table1.json").read_text()))


def published(commands: list[Command], kind: type[M]) -> list[M]:
    """Messages of type ``kind`` among the Publish commands."""
    return [
        c.message
        for c in commands
        if isinstance(c, Publish) and isinstance(c.message, kind)
    ]


def statuses(commands: list[Command], event: str) -> list[messages.Status]:
    """Status messages reporting ``event``."""
    return [
        s for s in published(commands, messages.Status) if s.event == event
    ]


def small_goal(goal_id: str, *task_ids: str) -> dict:
    """A goal of short, cheap tasks that fit anywhere in Table 1."""
    return {
        "goal_id": goal_id,
        "tasks": [
            {
                "id": task_id,
                "length": 1,
                "delay_cost": 1,
                "schedule_cost": 2,
                "uses": {"power": 5},
            }
            for task_id in task_ids
        ],
    }


def _without_timings(value: Any) -> Any:
    """Drop solver statistics and timings, which vary between runs."""
    if isinstance(value, dict):
        return {
            k: _without_timings(v)
            for k, v in value.items()
            if k not in ("stats", "wall_s", "build_s", "solve_s")
        }
    if isinstance(value, list):
        return [_without_timings(v) for v in value]
    return value


def encoded(commands: list[Command]) -> list[Any]:
    """``commands`` as plain data without timings, for comparisons."""
    return [
        [type(c).__name__, _without_timings(msgspec.to_builtins(c))]
        for c in commands
    ]
