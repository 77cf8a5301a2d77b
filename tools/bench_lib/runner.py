"""Run benchmark problems through the solvers, check and compare the plans.

Solvers, by name:

``cbc``, ``highs``
    :func:`fsw_scheduler.solving.solve.solve` (the time-indexed ILP), one
    thread.
``cpsat``, ``cpsat2``
    :func:`bench_lib.cpsat.solve_cpsat` with one and two workers.

Every plan that comes with a status having a plan is checked with
:func:`fsw_scheduler.analysis.check.check_plan`; objectives are compared across
solvers wherever at least two of them prove optimality.
"""

from __future__ import annotations

import functools
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TextIO

from fsw_scheduler.analysis.check import check_plan
from fsw_scheduler.model.plan import SolveStatus
from fsw_scheduler.model.problem import decode_problem

if TYPE_CHECKING:
    from fsw_scheduler.model.plan import Plan
    from fsw_scheduler.model.problem import Problem

    from .generator import BenchProblem

SOLVERS: tuple[str, ...] = ("cbc", "highs", "cpsat", "cpsat2")
ILP_SOLVERS: tuple[str, ...] = ("cbc", "highs")

SolveFn = Callable[["Problem", "float | None", int], "Plan"]


@dataclass
class Run:
    """One solve of one problem by one solver, with its check.

    Times are in seconds. ``wall_s`` is measured around the whole call;
    ``overhead_s`` is ``wall_s - build_s - solve_s`` (solver start-up,
    file hand-over, solution read-back).
    """

    problem: str
    suite: str
    num_tasks: int
    resource_class: str
    horizon: int
    seed: int
    solver: str
    repeat: int
    status: str
    timeout: bool
    build_s: float
    solve_s: float
    overhead_s: float
    wall_s: float
    unscheduled_cost: int | None = None
    delay_cost: int | None = None
    total: int | None = None
    bound: float | None = None
    num_variables: int = 0
    num_constraints: int = 0
    check_violations: int = 0
    check_detail: str = ""
    error: str = ""
    solver_status: str = ""

    @property
    def check_failed(self) -> bool:
        """True if the plan broke a rule or the solve raised."""
        return bool(self.check_violations or self.error)


@dataclass
class Disagreement:
    """Solvers that contradict each other on one problem."""

    problem: str
    seed: int
    detail: str
    path: str = ""


@dataclass
class Outcome:
    """Everything a benchmark run produced."""

    runs: list[Run] = field(default_factory=list)
    disagreements: list[Disagreement] = field(default_factory=list)


def solver_fn(name: str) -> SolveFn:
    """Return ``f(problem, time_limit, seed) -> Plan`` for solver ``name``.

    Parameters
    ----------
    name
        One of :data:`SOLVERS`.

    Returns
    -------
    callable
        The solve function.

    Raises
    ------
    ValueError
        For an unknown solver name.
    """
    if name in ILP_SOLVERS:
        from fsw_scheduler.solving.solve import solve

        def ilp(problem: Problem, limit: float | None, seed: int) -> Plan:
            return solve(
                problem, solver=name, time_limit=limit, threads=1, seed=seed
            )

        return ilp
    if name in ("cpsat", "cpsat2"):
        from .cpsat import solve_cpsat

        workers = 1 if name == "cpsat" else 2

        def cpsat(problem: Problem, limit: float | None, seed: int) -> Plan:
            return solve_cpsat(
                problem, time_limit=limit, workers=workers, seed=seed
            )

        return cpsat
    raise ValueError(f"unknown solver {name!r} (known: {', '.join(SOLVERS)})")


_WARMUP = b"""{"horizon": 6, "resources": {"binary": ["r"]}, "tasks": [
 {"id": "a", "length": 2, "delay_cost": 1, "schedule_cost": 1,
  "uses": {"r": 1}},
 {"id": "b", "length": 2, "delay_cost": 2, "schedule_cost": 0,
  "uses": {"r": 1}}]}"""


def warm_up(solvers: Sequence[str]) -> None:
    """Solve a 2-task problem once per solver so imports are not timed."""
    problem = decode_problem(_WARMUP)
    for name in solvers:
        solver_fn(name)(problem, 10.0, 0)


def run_one(
    bench: BenchProblem,
    problem: Problem,
    solver: str,
    repeat: int,
    time_limit: float | None,
    seed: int,
) -> Run:
    """Solve ``problem`` once with ``solver`` and check the plan.

    An exception is recorded in ``Run.error`` (status ``error``) rather
    than raised, so one broken solve does not stop the campaign.
    """
    base = functools.partial(
        Run,
        problem=bench.name,
        suite=bench.suite,
        num_tasks=bench.num_tasks,
        resource_class=bench.resource_class,
        horizon=bench.horizon,
        seed=bench.seed,
        solver=solver,
        repeat=repeat,
    )
    fn = solver_fn(solver)
    began = time.perf_counter()
    try:
        plan = fn(problem, time_limit, seed)
    except Exception as error:  # recorded, reported as a check failure
        wall = time.perf_counter() - began
        detail = traceback.format_exception_only(error)[-1].strip()
        return base(
            status="error",
            timeout=False,
            build_s=0.0,
            solve_s=0.0,
            overhead_s=wall,
            wall_s=wall,
            error=detail,
        )
    wall = time.perf_counter() - began
    stats = plan.stats
    build = stats.build_s if stats else 0.0
    solve = stats.solve_s if stats else 0.0
    report = check_plan(problem, plan)
    objective = plan.objective
    return base(
        status=plan.status.value,
        timeout=plan.status in (SolveStatus.FEASIBLE, SolveStatus.UNKNOWN),
        build_s=build,
        solve_s=solve,
        overhead_s=max(0.0, wall - build - solve),
        wall_s=wall,
        unscheduled_cost=objective.unscheduled_cost if objective else None,
        delay_cost=objective.delay_cost if objective else None,
        total=objective.total if objective else None,
        bound=stats.bound if stats else None,
        num_variables=stats.num_variables if stats else 0,
        num_constraints=stats.num_constraints if stats else 0,
        solver_status=stats.solver_status if stats else "",
        check_violations=len(report.violations),
        check_detail="; ".join(
            f"{v.rule}: {v.detail}" for v in report.violations[:3]
        ),
    )


def compare(runs: Sequence[Run]) -> list[str]:
    """Return the contradictions between runs of one problem (empty: ok).

    Contradictions: two proven optima with different totals; a proven
    optimum beaten by a checked plan of another solver; ``infeasible``
    from one solver while another returns a checked plan.
    """
    problems: list[str] = []
    optimal = sorted(
        {
            r.total
            for r in runs
            if r.status == "optimal" and r.total is not None
        }
    )
    if len(optimal) > 1:
        who = ", ".join(
            f"{r.solver}={r.total}" for r in runs if r.status == "optimal"
        )
        problems.append(f"proven optima differ: {who}")
    valid = [
        r
        for r in runs
        if r.status in ("optimal", "feasible")
        and not r.check_failed
        and r.total is not None
    ]
    if optimal and valid:
        best = min(valid, key=lambda r: r.total or 0)
        if best.total is not None and best.total < optimal[0]:
            problems.append(
                f"{best.solver} found a valid plan of total {best.total} "
                f"below the proven optimum {optimal[0]}"
            )
    infeasible = sorted({r.solver for r in runs if r.status == "infeasible"})
    if infeasible and valid:
        problems.append(
            f"{', '.join(infeasible)} say infeasible but "
            f"{valid[0].solver} returned a valid plan"
        )
    return problems


def run_suite(
    problems: Sequence[BenchProblem],
    solvers: Sequence[str],
    *,
    time_limit: float | None,
    repeat: int = 1,
    seed: int = 0,
    progress: TextIO | None = None,
    on_disagreement: Callable[[BenchProblem], str] | None = None,
    on_runs: Callable[[list[Run]], None] | None = None,
) -> Outcome:
    """Run every problem with every solver ``repeat`` times.

    Parameters
    ----------
    problems
        The generated problems.
    solvers
        Solver names (see :data:`SOLVERS`).
    time_limit
        Per-solve limit in seconds (None: none).
    repeat
        Solves per problem and solver.
    seed
        Solver seed.
    progress
        Where to write one line per problem (default stderr).
    on_disagreement
        Called with a problem whose solvers disagree; returns the path of
        its saved JSON.
    on_runs
        Called with each problem's runs as soon as they are done (e.g. to
        append them to a CSV file, so an interrupted benchmark keeps them).

    Returns
    -------
    Outcome
        All runs and all disagreements.
    """
    out = progress if progress is not None else sys.stderr
    outcome = Outcome()
    width = len(str(len(problems)))
    for index, bench in enumerate(problems, 1):
        problem = bench.problem()
        runs = [
            run_one(bench, problem, solver, rep, time_limit, seed)
            for rep in range(repeat)
            for solver in solvers
        ]
        outcome.runs += runs
        if on_runs is not None:
            on_runs(runs)
        cells = []
        for solver in solvers:
            mine = [r for r in runs if r.solver == solver]
            last = mine[-1]
            flag = " CHECK-FAILED" if any(r.check_failed for r in mine) else ""
            best = min(r.wall_s for r in mine)
            cells.append(f"{solver} {last.status} {best:.2f}s{flag}")
        print(
            f"[{index:{width}d}/{len(problems)}] {bench.name} "
            f"(seed {bench.seed}): " + " | ".join(cells),
            file=out,
            flush=True,
        )
        for run in runs:
            if run.check_failed:
                print(
                    f"  CHECK FAILED {bench.name} {run.solver}: "
                    f"{run.error or run.check_detail}",
                    file=out,
                    flush=True,
                )
        issues = compare(runs)
        if issues:
            path = on_disagreement(bench) if on_disagreement else ""
            for issue in issues:
                outcome.disagreements.append(
                    Disagreement(bench.name, bench.seed, issue, path)
                )
                print(
                    f"  !!! DISAGREEMENT {bench.name} (seed {bench.seed}): "
                    f"{issue} [{path}]",
                    file=out,
                    flush=True,
                )
    return outcome
