"""The cost of stability: the campaign's replans with and without moves.

For each campaign problem: its plan (CBC) is the plan in force; the
replan is the same problem with one more task, a copy of its longest
scheduled task with twice its schedule cost (a goal that competes for the
same resources), the previous starts those of the plan. It is solved
with stability ``off``, ``moves`` (at 5 a move) and ``lexicographic``;
each plan is checked with the move part, and the report gives the solve
times and the moves per mode. ``.venv/bin/python tools/bench --suite
stability``.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import msgspec

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.model.stability import Stability
from fsw_scheduler.solving.solve import solve

if TYPE_CHECKING:
    from collections.abc import Sequence

    from fsw_scheduler.model.problem import Problem
    from fsw_scheduler.model.stability import Mode

    from .generator import BenchProblem

MODES: tuple[Mode, ...] = ("off", "moves", "lexicographic")

#: The price of a move under ``moves`` (the setting's default).
MOVE_COST = 5


@dataclass
class StableRun:
    """One replan solved in one mode."""

    problem: str
    mode: str
    status: str
    seconds: float
    moves: int
    unscheduled_cost: int
    ok: bool


def replan_of(
    bench: BenchProblem, time_limit: float
) -> tuple[Problem, dict[str, int]]:
    """The replan problem of ``bench`` and its previous starts."""
    problem = decode_problem(msgspec.json.encode(bench.doc))
    plan = solve(problem, time_limit=time_limit)
    previous = plan.starts()
    if not previous:
        return problem, previous
    longest = max(
        (problem.task(name) for name in previous), key=lambda t: t.length
    )
    extra = msgspec.structs.replace(
        longest,
        id=f"{longest.id}-again",
        schedule_cost=min(5, 2 * max(longest.schedule_cost, 1)),
        fixed_start=None,
    )
    return problem.replace(tasks=(*problem.tasks, extra)), previous


def run_stability(
    problems: Sequence[BenchProblem], time_limit: float
) -> list[StableRun]:
    """Solve each problem's replan in every mode."""
    runs = []
    for bench in problems:
        problem, previous = replan_of(bench, time_limit)
        for mode in MODES:
            stability = Stability(previous, mode, MOVE_COST)
            began = time.perf_counter()
            plan = solve(
                problem,
                time_limit=time_limit,
                stability=stability,
            )
            seconds = time.perf_counter() - began
            moved = stability.moves(problem, plan.starts())
            report = check_plan(problem, plan, stability)
            runs.append(
                StableRun(
                    bench.name,
                    mode,
                    plan.status.value,
                    seconds,
                    moved if plan.status.has_plan else 0,
                    plan.objective.unscheduled_cost if plan.objective else -1,
                    report.ok or not plan.status.has_plan,
                )
            )
    return runs


def format_stability(runs: Sequence[StableRun]) -> str:
    """A table: per mode, solve time (median, max, total), moves and
    unscheduled cost summed over the replans, statuses."""
    lines = [
        "| stability | replans | median s | max s | total s | moves | "
        "unscheduled cost | optimal | checker |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for mode in MODES:
        mine = [r for r in runs if r.mode == mode]
        if not mine:
            continue
        times = [r.seconds for r in mine]
        lines.append(
            f"| {mode} | {len(mine)} | {statistics.median(times):.3f} | "
            f"{max(times):.3f} | {sum(times):.1f} | "
            f"{sum(r.moves for r in mine)} | "
            f"{sum(max(r.unscheduled_cost, 0) for r in mine)} | "
            f"{sum(r.status == 'optimal' for r in mine)} | "
            f"{'all pass' if all(r.ok for r in mine) else 'FAILS'} |"
        )
    return "\n".join(lines)
