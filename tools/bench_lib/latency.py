"""End-to-end replan latency on the bus: goal published to plan received.

Each repetition opens a fresh :class:`~fsw_scheduler.testing.SchedulerHarness`
(two in-process loopback Zenoh peers, the real scheduler node, bus clock)
on the paper's Table 1 problem, lets the node adopt its initial plan at
t=0, moves the clock to t=15 and measures two replans from the client
side:

``paper-goal``
    The paper's Table 2 goal (``monitor-target-lf``, three tasks).
``ping-goal``
    A one-task goal, published once the first replan has settled.

The latency is taken with :func:`time.perf_counter` around the publish
and the moment the waiting client thread sees the plan, so it includes
the bus both ways, the node's input handling, the model build, the solve
and the plan's publication. The plan's own solver statistics give the
solver wall time; the remainder is reported as bus + engine overhead.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from fsw_scheduler.testing import (
    WAIT_S,
    SchedulerHarness,
    harness_config,
    paper_goal,
    paper_problem,
)

from .report import aligned, fmt, percentile

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

SCENARIOS: tuple[str, ...] = ("paper-goal", "ping-goal")

#: Bus time at which the paper's goal arrives (Table 2).
GOAL_AT = 15


@dataclass
class LatencyRun:
    """One measured replan; times in seconds.

    ``latency_s`` runs from just before the client publishes the goal to
    the client holding the plan that adopts it. ``solver_wall_s`` is the
    plan's ``stats.wall_s`` (None when the plan has no statistics) and
    ``overhead_s`` is ``latency_s - solver_wall_s``: bus, node inbox,
    engine, greedy start and plan publication.
    """

    scenario: str
    repeat: int
    latency_s: float
    solver_wall_s: float | None
    overhead_s: float | None
    plan_id: int
    status: str
    solver: str = ""


def ping_goal(goal_id: str) -> dict[str, Any]:
    """A goal of one short, cheap task that fits at once.

    Parameters
    ----------
    goal_id
        The goal's id; use a fresh one per publication.

    Returns
    -------
    dict
        The goal document.
    """
    return {
        "goal_id": goal_id,
        "tasks": [
            {
                "id": f"Ping-{goal_id}",
                "length": 1,
                "delay_cost": 5,
                "schedule_cost": 3,
                "uses": {"power": 5},
            }
        ],
    }


def _replan(
    harness: SchedulerHarness,
    scenario: str,
    repeat: int,
    goal: dict[str, Any],
) -> LatencyRun:
    """Publish ``goal`` and time until the plan adopting it arrives."""
    goal_id = goal["goal_id"]
    # Only plans received after the publish may count.
    since = len(harness.plans)
    began = time.perf_counter()
    harness.publish_goal(goal)
    plan = harness.wait_plan(lambda p: goal_id in p.goals, since=since)
    latency = time.perf_counter() - began
    wall = plan.stats.wall_s if plan.stats is not None else None
    return LatencyRun(
        scenario=scenario,
        repeat=repeat,
        latency_s=latency,
        solver_wall_s=wall,
        overhead_s=None if wall is None else latency - wall,
        plan_id=plan.plan_id,
        status=plan.status.value,
        solver=plan.stats.solver if plan.stats is not None else "",
    )


def measure(
    repeat: int,
    time_limit: float,
    on_progress: Callable[[LatencyRun], None] | None = None,
) -> list[LatencyRun]:
    """Measure the replan latency of both scenarios ``repeat`` times.

    Parameters
    ----------
    repeat
        Repetitions; each opens a fresh harness (new Zenoh sessions and
        node) and measures every scenario once.
    time_limit
        The node's per-solve limit in seconds.
    on_progress
        Called with each run as soon as it is measured.

    Returns
    -------
    list of LatencyRun
        ``len(SCENARIOS) * repeat`` runs, in measurement order.

    Raises
    ------
    TimeoutError
        If the node does not answer or publish a plan in time.
    """
    runs: list[LatencyRun] = []
    config = harness_config(time_limit=time_limit)
    # Every wait must outlast a solve that uses its whole limit.
    timeout = time_limit + WAIT_S
    for rep in range(repeat):
        with SchedulerHarness(
            paper_problem(), config, timeout=timeout
        ) as harness:
            harness.tick(0)
            harness.wait_plan(lambda p: p.plan_id == 1)
            harness.tick(GOAL_AT)
            goals = (paper_goal(), ping_goal(f"ping-{rep}"))
            for scenario, goal in zip(SCENARIOS, goals, strict=True):
                run = _replan(harness, scenario, rep, goal)
                # Let the node finish its follow-up work (dispatches,
                # status) so the next measurement starts from idle.
                harness.settle(GOAL_AT)
                runs.append(run)
                if on_progress is not None:
                    on_progress(run)
    return runs


def _median(values: Sequence[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return statistics.median(known) if known else None


HEADER = (
    "scenario",
    "runs",
    "median",
    "p90",
    "max",
    "solver",
    "overhd",
)


def format_latency(runs: Sequence[LatencyRun]) -> str:
    """Render the latency table, one row per scenario.

    Parameters
    ----------
    runs
        The measured runs.

    Returns
    -------
    str
        A one-line legend and an aligned table.
    """
    cells = [HEADER]
    names = list(dict.fromkeys(r.scenario for r in runs))
    for name in names:
        mine = [r for r in runs if r.scenario == name]
        latencies = [r.latency_s for r in mine]
        cells.append(
            (
                name,
                str(len(mine)),
                fmt(statistics.median(latencies)),
                fmt(percentile(latencies, 90)),
                fmt(max(latencies)),
                fmt(_median([r.solver_wall_s for r in mine])),
                fmt(_median([r.overhead_s for r in mine])),
            )
        )
    legend = (
        "Replan latency in seconds, client side on an in-process loopback "
        "bus: goal published to plan received (median/p90/max); solver = "
        "median of the plan's solver wall time; overhd = median of latency "
        "minus solver wall (bus, node, engine, publication)."
    )
    return "\n".join([legend, "== replan latency", *aligned(cells, 1)])
