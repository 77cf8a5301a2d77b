"""Build the ILP, run CBC or HiGHS, and read the solver's own status.

PuLP's ``status`` says "Optimal" whenever an integer solution was found,
even when a time limit stopped the search; ``sol_status`` tells proven
optimality from "best found at the limit", so that is what is mapped.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pulp

from ...domains import start_domains
from ...errors import SolverError
from ...solution import (
    Activity,
    Objective,
    Plan,
    SolverStats,
    SolveStatus,
)
from .cbc import GRACE_S, HardLimitCBC
from .constraints import Constraints
from .objective import objective, weight
from .variables import Variables

if TYPE_CHECKING:
    from collections.abc import Iterator

    from ...model import Problem

SOLVERS = ("cbc", "highs")

# Every objective coefficient is an integer, so an absolute gap below one
# already proves the optimum; a relative gap would stop early on the big
# weight of the lexicographic objective.
_ABS_GAP = 0.5

_STATUS = {
    pulp.LpSolutionOptimal: SolveStatus.OPTIMAL,
    pulp.LpSolutionIntegerFeasible: SolveStatus.FEASIBLE,
    pulp.LpSolutionInfeasible: SolveStatus.INFEASIBLE,
    pulp.LpSolutionNoSolutionFound: SolveStatus.UNKNOWN,
    pulp.LpSolutionUnbounded: SolveStatus.UNKNOWN,
}


def _read_status(lp: pulp.LpProblem) -> SolveStatus:
    """The solve's status, from the solution status first.

    CBC's "Integer infeasible" result sets PuLP's ``status`` to infeasible
    but leaves ``sol_status`` at "no solution found", so a proven
    infeasibility is read from ``status``.
    """
    if lp.status == pulp.LpStatusInfeasible:
        return SolveStatus.INFEASIBLE
    return _STATUS.get(lp.sol_status, SolveStatus.UNKNOWN)


class BuiltModel:
    """A problem's ILP: PuLP problem plus the variables that decode it."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.domains = start_domains(problem)
        self.lp = pulp.LpProblem("schedule", pulp.LpMinimize)
        self.vars = Variables(self.lp, problem, self.domains)
        self.constraints = Constraints(self.lp, problem, self.vars)
        self.constraints.add_all()
        self.lp.setObjective(objective(problem, self.vars))

    @property
    def num_variables(self) -> int:
        """Number of variables handed to the solver."""
        return len(self.lp.variables())

    @property
    def num_constraints(self) -> int:
        """Number of rows handed to the solver."""
        return self.lp.numConstraints()

    def decode(self, status: SolveStatus) -> Plan:
        """Read the solution into a Plan with the objective recomputed."""
        activities, unscheduled = [], []
        delay = unscheduled_cost = 0
        for task in self.problem.tasks:
            start = self.vars.start_of(task.id)
            if start is None:
                unscheduled.append(task.id)
                unscheduled_cost += task.schedule_cost
                continue
            activities.append(Activity(task.id, start, start + task.length))
            delay += task.delay_cost * (start - self.problem.start)
        activities.sort(key=lambda a: (a.start, a.task))
        total = weight(self.problem) * unscheduled_cost + delay
        return Plan(
            status=status,
            objective=Objective(unscheduled_cost, delay, total),
            activities=tuple(activities),
            unscheduled=tuple(unscheduled),
        )


def cbc_path() -> str:
    """The CBC executable: PuLP's bundled binary, else ``cbc`` on PATH.

    ``PULP_CBC_CMD`` (which uses the bundled binary) is deprecated in favour
    of ``COIN_CMD``, which only looks on PATH; pointing ``COIN_CMD`` at the
    bundled binary keeps a plain ``pip install`` self-sufficient.
    """
    from pulp.apis import coin_api

    bundled = Path(coin_api.pulp_cbc_path)
    if bundled.is_file() and os.access(bundled, os.X_OK):
        return str(bundled.resolve())
    found = shutil.which("cbc")
    if found is None:
        raise SolverError(
            "no CBC executable: PuLP's bundled one is missing and 'cbc' is "
            "not on PATH (pip install 'pulp[cbc]' or apt install coinor-cbc)"
        )
    return found


def _backend(
    solver: str,
    time_limit: float | None,
    threads: int,
    seed: int,
    warm: bool,
    log_path: str,
) -> pulp.LpSolver:
    if solver == "cbc":
        return HardLimitCBC(
            deadline_s=None if time_limit is None else time_limit + GRACE_S,
            path=cbc_path(),
            msg=False,
            threads=threads,
            timeLimit=time_limit,
            gapRel=0.0,
            gapAbs=_ABS_GAP,
            warmStart=warm,
            logPath=log_path,
            options=[
                # CBC's own seeds: the same input gives the same plan.
                f"randomSeed {seed + 1}",
                f"randomCbcSeed {seed + 1}",
                # CGL preprocessing costs more than it saves on these
                # models: half the median time on the paper's campaign
                # (tools/bench, 15 tasks: 0.67 s -> 0.31 s).
                "preprocess off",
            ],
        )
    if solver == "highs":
        if not pulp.HiGHS().available():
            raise SolverError(
                "HiGHS is not installed: pip install 'fsw-scheduler[highs]'"
            )
        return pulp.HiGHS(
            msg=False,
            threads=threads,
            timeLimit=time_limit,
            gapRel=0.0,
            gapAbs=_ABS_GAP,
            random_seed=seed,
        )
    raise SolverError(f"unknown solver {solver!r} (choose from {SOLVERS})")


@contextlib.contextmanager
def _stdout_to_stderr(active: bool) -> Iterator[None]:
    """Send fd 1 to stderr while active.

    The HiGHS library prints its banner from C++ when the solver object is
    created, before any option can silence it; on stdout it would corrupt
    the plan JSON that ``fsw-scheduler solve`` prints.
    """
    if not active:
        yield
        return
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


_CBC_SECONDS = re.compile(r"Time \(Wallclock seconds\):\s+([0-9.eE+-]+)")
_CBC_BOUND = re.compile(r"Lower bound:\s+([0-9.eE+-]+)")


def _read_cbc_log(path: str) -> tuple[float | None, float | None]:
    """(solve seconds, lower bound) from a CBC log, when it states them."""
    try:
        text = Path(path).read_text(errors="replace")
    except OSError:
        return None, None
    seconds = _CBC_SECONDS.findall(text)
    bound = _CBC_BOUND.findall(text)
    return (
        float(seconds[-1]) if seconds else None,
        float(bound[-1]) if bound else None,
    )


def _highs_bound(lp: pulp.LpProblem) -> float | None:
    model = getattr(lp, "solverModel", None)
    if model is None:
        return None
    try:
        return float(model.getInfo().mip_dual_bound)
    except (AttributeError, TypeError, ValueError):
        return None


def solve_ilp(
    problem: Problem,
    solver: str = "cbc",
    *,
    time_limit: float | None = None,
    threads: int = 1,
    seed: int = 0,
    warm: dict[str, int] | None = None,
) -> Plan:
    """Build and solve the ILP of ``problem``.

    Parameters
    ----------
    problem
        A validated problem.
    solver
        ``cbc`` (default) or ``highs``.
    time_limit
        Seconds; at the limit the best plan found is returned with status
        ``feasible``, or status ``unknown`` if none was found.
    threads
        Solver threads; 1 keeps results reproducible.
    seed
        Solver random seed.
    warm
        Task id to start time of a known plan, used as a MIP start.

    Returns
    -------
    Plan
        With ``stats`` filled; without ``why`` (see
        :mod:`fsw_scheduler.explain`).
    """
    began = time.perf_counter()
    built = BuiltModel(problem)
    if warm:
        built.vars.set_initial(warm)
    built_at = time.perf_counter()
    impossible = [
        task.id
        for task in problem.tasks
        if task.mandatory and not built.vars.placeable(task.id)
    ]
    stats: dict[str, Any] = dict(
        solver=solver,
        build_s=built_at - began,
        num_variables=built.num_variables,
        num_constraints=built.num_constraints,
        time_limit_s=time_limit,
    )
    if impossible:
        # No need to ask the solver: a mandatory task has no start time.
        return _without_plan(problem, SolveStatus.INFEASIBLE, stats, began)
    if not built.vars.steps:
        plan = built.decode(SolveStatus.OPTIMAL)
        return plan.replace(
            stats=SolverStats(
                **stats,
                wall_s=time.perf_counter() - began,
                solver_status="trivial",
            )
        )
    handle, log_path = tempfile.mkstemp(prefix="fsw-cbc-", suffix=".log")
    os.close(handle)
    try:
        backend = _backend(
            solver, time_limit, threads, seed, bool(warm), log_path
        )
        try:
            with _stdout_to_stderr(solver == "highs"):
                built.lp.solve(backend)
        except pulp.PulpSolverError as error:
            raise SolverError(f"{solver} failed: {error}") from error
        solved_at = time.perf_counter()
        solver_seconds, bound = (
            _read_cbc_log(log_path) if solver == "cbc" else (None, None)
        )
    finally:
        Path(log_path).unlink(missing_ok=True)
    if solver == "highs":
        bound = _highs_bound(built.lp)
    status = _read_status(built.lp)
    call = solved_at - built_at
    solve_s = solver_seconds if solver_seconds is not None else call
    stats.update(
        solve_s=solve_s,
        overhead_s=max(call - solve_s, 0.0),
        solver_status=pulp.LpStatus.get(built.lp.status, "?")
        + f"/{built.lp.sol_status}",
    )
    if not status.has_plan:
        return _without_plan(problem, status, stats, began)
    plan = built.decode(status)
    if status is SolveStatus.OPTIMAL:
        bound = plan.objective.total if plan.objective else bound
    return plan.replace(
        stats=SolverStats(
            **stats, bound=bound, wall_s=time.perf_counter() - began
        )
    )


def _without_plan(
    problem: Problem,
    status: SolveStatus,
    stats: dict[str, Any],
    began: float,
) -> Plan:
    return Plan(
        status=status,
        objective=None,
        unscheduled=tuple(task.id for task in problem.tasks),
        stats=SolverStats(**stats, wall_s=time.perf_counter() - began),
    )
