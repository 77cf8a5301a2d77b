"""Build the ILP, run CBC or HiGHS, and read the solver's own status.

CBC runs as a child process on an MPS file (:mod:`.cbc`); HiGHS is reached
through PuLP, whose ``sol_status`` (not its ``status``, which says
"Optimal" whenever an integer solution was found, even when a time limit
stopped the search) tells proven optimality from "best found at the
limit".
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import msgspec

from ...analysis.domains import start_count, start_domains
from ...errors import SolverError
from ...model.plan import Plan, SolverStats, SolveStatus
from ..stats import higher, stopped_on_nodes
from .alternatives import impossible_groups
from .cbc import ABS_GAP, MIN_CBC_S, CbcResult, cbc_path, read_completed
from .constraints import Constraints
from .decode import Formulation
from .disjunctive.model import DisjunctiveModel
from .disjunctive.rule import (
    FORMULATIONS,
    pick,
    switch_nodes,
    used_kinds,
)
from .objective import objective
from .progress import WITH_START, WITH_START_DISJUNCTIVE, WatchedCbcRun
from .variables import Variables, with_starts

if TYPE_CHECKING:
    from collections.abc import Iterator, Mapping, Sequence

    import pulp

    from ...analysis.domains import Domain
    from ...model.problem import Problem
    from ...model.stability import Stability
    from .program import Program

SOLVERS = ("cbc", "highs")


def backend_ready(solver: str) -> None:
    """Do once per process what the first run of ``solver`` would do
    first: find CBC's executable, or import PuLP for HiGHS.

    Either imports PuLP (about 0.1 s: it imports HiGHS's bindings and
    NumPy). :func:`~fsw_scheduler.solving.solve.solve` calls this on its
    clock, before it shares out its limit, so that the first solve of a
    process still answers within it (a 0.3 s limit was answered after
    0.35-0.39 s when the import fell inside CBC's share).
    """
    if solver == "cbc":
        cbc_path()
    else:
        import pulp  # noqa: F401


#: Seconds to build and write a model, per column (measured: 2.9 s for the
#: 158 000 columns of 200 tasks at H = 1440, 18 us each; rounded up).
BUILD_S_PER_COLUMN = 2.5e-5

#: CBC options added to :data:`~.progress.WITH_START` for a part whose only
#: resources in use are consumables. With a MIP start CBC proves these at
#: the root, by reduced costs, and its cut rounds cost more than they
#: close: CPU time 1.54 -> 1.04 s in total on the 12 consumable models of
#: the paper campaign's 10 and 15 tasks, 0.42 -> 0.25 s on the 11 of the
#: broad campaign (none slower by more than 0.04 s). With binary or
#: multiple resources the cuts close most of the root gap, and stay.
#: Strong branching stays on: off, it saved 13 % of CBC's time on the easy
#: models, but a 10-task paper problem (c10-consumable-5 of seed 4, a
#: generator tied to a late window) then searched 6,000 nodes in 20 s
#: without closing a gap of 162, where with it CBC proves it in 14 nodes,
#: 0.35 s. Paper consumable problems of seeds 0-9 (210): 29.0 -> 10.6 s in
#: all, median 0.0094 -> 0.0102 s.
CONSUMABLES_ONLY = ["cuts off"]

#: CBC options added to :data:`~.progress.WITH_START` for a time-indexed
#: part with a consumable in use beside a binary or multiple resource
#: (the campaign's ``all`` class) whose MIP start leaves no placeable
#: task out, so that only delay is left to optimise. There the root LP
#: is close (seed 1's c15-all-4: -318,943, cuts -318,935 in 10 passes,
#: optimum -318,876) and the dense Gomory and two-MIR rows (200+
#: entries each) slow every node's LP and strong branching: CBC's CPU
#: time summed over the 22 problems of seeds 1-6, 9-10 whose plans leave
#: nothing out (both generators, 15 tasks, the all class), each solved
#: with and without, went 22.4 -> 17.2 s (c15-all-0 of seed 2 4.3 ->
#: 1.4 s). Where the start leaves
#: tasks out the cuts close the choice of what to keep (seed 2's
#: b15-all-0: root LP 162,422, after cuts 209,446, the optimum), and
#: off they cost more: 57.6 -> 71.0 s on the other 79. Parts without a
#: consumable keep the cuts too (off: seed 3's c15-multiple-6 2.5 ->
#: 3.7 s). Only parts of up to :data:`TUNED_MAX_TASKS` tasks and
#: under :data:`LARGE_ROWS` rows: the models measured have 2,000-5,000
#: rows and at most 15 tasks.
CONSUMABLES_AND_SHARED = ["cuts off"]

#: CBC options added to :data:`~.progress.WITH_START` for a time-indexed
#: part with a multiple resource in use and no consumable: strong
#: branching on 2 candidates instead of CBC's 5. In these models most of
#: CBC's time is strong branching (seed 5's b15-multiple-3: 1,226 strong
#: branches, 38,549 of 59,336 LP iterations), and its 5 candidates bring
#: few more fathoms than 2. CBC's CPU time on the 15 time-indexed models
#: of the slowest 15-task multiple problems of seeds 1-6 and 9 (CBC
#: alone on the same model files): 48.2 -> 42.1 s (``trust 1``: 42.3 s,
#: not kept beside it); the product on the 27 slowest multiple problems
#: of seeds 1-6, 9-10 side by side: 79.9 -> 75.2 s, 5 -> 4 unproved;
#: on seeds 13-14 (not tuned on), all 28: 15.9 -> 15.1 s. A small gain,
#: no problem slower beyond a rerun's spread.
#:
#: Two-MIR and zero-half cuts off as well: at the root of these models
#: they are the costliest generators (0.07 s each of a 0.5 s solve on
#: broad seed 98's b15-multiple-2, 16 passes) and none of their cuts was
#: still active at the end on the models looked at. CBC alone on the 10
#: slowest time-indexed multiple models of seeds 97-98: 8.8 -> 6.9 s;
#: on the 26 of seeds 100-101 (not looked at before), twice each: 4.9 ->
#: 3.9 s (one 2.2 -> 2.5 s, one 1.6 -> 0.8 s), the same optima.
#:
#: At most 10 passes of cuts at the root (CBC's default ran 36 on broad
#: seed 103's b15-multiple-4, 1.25 s, then a restart and 74 nodes: 4.3 s
#: in all; with 10 passes 1.0 s and 12 nodes): CBC alone on the
#: models of the multiple problems of seeds 97-98 and 100-103 (66
#: models), 21.7 -> 16.6 s, the slowest 4.6 -> 1.0 s and 3.2 -> 1.0 s,
#: two slower (1.9 -> 2.9 s, 2.1 -> 2.5 s); on seeds 104-105, not looked
#: at before (28 models), 1.85 -> 1.40 s, none slower. 3 passes lost on
#: seeds 100-101 (4.3 s against 3.9 s), 20 kept most of the tail (9.3
#: against 6.5 s on seeds 102-103).
MULTIPLE_TIME_INDEXED = ["strong 2", "twoMir off", "zeroHalf off", "passC 10"]

#: CBC options added to :data:`~.progress.WITH_START_DISJUNCTIVE` for
#: a part with a multiple resource in use (of up to
#: :data:`TUNED_MAX_TASKS` tasks): strong branching on 10 candidates
#: instead of 5. Without cuts the disjunctive model's bound rises only
#: by branching on the order binaries, and a better choice of branch
#: closes it in fewer nodes: CBC alone on seed 4's b15-multiple-2 11.1 ->
#: 4.5 s (with 2 candidates 12.0 s), seed 6's b15-multiple-6 7.6 ->
#: 3.8 s. The product on the 112 multiple problems of seeds 1-6 and
#: 9-10 (both generators, 15 tasks), side by side: CBC time 80.3 ->
#: 78.8 s, unproved in 20 s 5 -> 3 (those two); on seeds 13-14 (not
#: tuned on), 28 problems: 16.5 -> 15.3 s, none slower by more than
#: 0.02 s (c15-multiple-5 of seed 14 1.76 -> 1.09 s). Binary-only parts
#: branch on fewer candidates instead (:data:`BINARY_STRONG`).
#:
#: ``depthMiniBab -999`` turns off CBC's mini branch-and-bound ("complete
#: fathoming": small models of under 500 rows and columns get it by
#: default), whose nodes neither count against a node limit nor close
#: the weak bound any sooner: seed 33's b15-multiple-5 ran 60,437 nodes,
#: 59,713 of them in it, in 2.3 s (a node limit of 5,000 set), and 2,123
#: nodes in 0.61 s without it. On the 22 disjunctive multiple parts of
#: ``--generator broad --seed 32..39 --only b15-multiple`` it took 27.6
#: -> 23.8 s in total (with :data:`~.disjunctive.rule.SWITCH_NODES`:
#: 16.7 s). Binary-only parts keep it: two of their tails went 6.7 ->
#: 15.3 s and 11.0 s -> unproved at 20 s without it. (``depthMiniBab
#: 0`` makes CBC 2.10.3 crash: never use it.)
DISJUNCTIVE_STRONG = ["strong 10", "depthMiniBab -999"]

#: CBC options added to :data:`~.progress.WITH_START_DISJUNCTIVE` for a
#: part whose only resources in use are binary (of up to
#: :data:`TUNED_MAX_TASKS` tasks): strong branching on 2 candidates
#: instead of 5. The product on the 56 binary problems of ``--generator
#: broad --seed 32..39 --only b15-binary`` (median of 3 runs each): 23.4
#: -> 18.4 s in total, the slowest 10.1 -> 7.3 s and 6.9 -> 5.6 s, 9
#: problems faster by more than 30 %, 3 slower. On seeds not looked at
#: (40-45, 42 problems of each generator): broad 4.37 -> 3.94 s, paper
#: 2.05 -> 1.83 s, one problem slower by more than 30 % (0.09 -> 0.15
#: s); the medians moved within a rerun's spread (0.041 -> 0.040 s,
#: 0.022 -> 0.024 s). With 10 candidates: 19.6 s on the first set.
BINARY_STRONG = ["strong 2"]

#: Parts of at most this many tasks get :data:`CONSUMABLES_AND_SHARED`
#: and :data:`MULTIPLE_TIME_INDEXED`: they were measured on 15-task
#: parts. The whole model of a 30-task part (seed 31's b30-h1440 of the
#: large suite, narrowed around its start: 4,344 rows, nothing left out)
#: took 3.8 s of CBC time with cuts off against 1.8 s with them.
TUNED_MAX_TASKS = 15

#: Rows from which a time-indexed model counts as large (:data:`LARGE`).
LARGE_ROWS = 12_000

#: CBC options for a large time-indexed model (long horizons): one round
#: of root cuts closes about the gap CBC's fifteen do (f20-h1440-1: bound
#: -4951173 after one pass, -4951152 after 15) at a tenth of the time.
LARGE = ["passCuts 1"]


def _pulp_status(lp: pulp.LpProblem) -> SolveStatus:
    """The status of a solve through PuLP, from the solution status first.

    A proven infeasibility can leave ``sol_status`` at "no solution found"
    with ``status`` infeasible, so that is read from ``status``.
    """
    import pulp

    if lp.status == pulp.LpStatusInfeasible:
        return SolveStatus.INFEASIBLE
    return {
        pulp.LpSolutionOptimal: SolveStatus.OPTIMAL,
        pulp.LpSolutionIntegerFeasible: SolveStatus.FEASIBLE,
        pulp.LpSolutionInfeasible: SolveStatus.INFEASIBLE,
    }.get(lp.sol_status, SolveStatus.UNKNOWN)


class BuiltModel(Formulation):
    """A problem's ILP: the program plus the variables that decode it.

    Parameters
    ----------
    problem
        A validated problem.
    domains
        Start domains to model (default :func:`start_domains`); narrower
        ones, such as those of
        :func:`fsw_scheduler.analysis.domains.cost_caps`,
        give a smaller model with the same optimum.
    stability
        See :class:`~.decode.Formulation`.
    candidates
        Candidate starts of some tasks (:class:`.variables.Variables`):
        a smaller model whose solutions are plans, its optimum not
        necessarily the problem's.
    """

    vars: Variables
    constraints: Constraints

    def __init__(
        self,
        problem: Problem,
        domains: dict[str, Domain] | None = None,
        stability: Stability | None = None,
        candidates: dict[str, list[int]] | None = None,
    ) -> None:
        super().__init__(
            problem,
            domains if domains is not None else start_domains(problem),
            Variables,
            Constraints,
            objective,
            stability,
            candidates=candidates,
        )


@contextlib.contextmanager
def _stdout_to_stderr() -> Iterator[None]:
    """Send fd 1 to stderr meanwhile.

    The HiGHS library prints its banner from C++ when the solver object is
    created, before any option can silence it; on stdout it would corrupt
    the plan JSON that ``fsw-scheduler solve`` prints.
    """
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def _highs_bound(lp: pulp.LpProblem) -> float | None:
    model = getattr(lp, "solverModel", None)
    if model is None:
        return None
    try:
        return float(model.getInfo().mip_dual_bound)
    except (AttributeError, TypeError, ValueError):
        return None


def in_symmetry_order(
    twins: list[list[str]], starts: dict[str, int]
) -> dict[str, int]:
    """``starts`` with identical tasks' starts sorted into problem order.

    The symmetry rows want the first of identical tasks (``twins``, from
    :func:`identical_tasks`) to start first; a MIP start breaking them
    would be refused. Swapping the starts of identical tasks changes
    nothing else, so the start is kept as good.
    """
    reordered = dict(starts)
    for group in twins:
        placed = [name for name in group if name in starts]
        times = sorted(starts[name] for name in placed)
        # The first len(placed) tasks of the class get the starts.
        for name in group:
            reordered.pop(name, None)
        for name, time_ in zip(group, times, strict=False):
            reordered[name] = time_
    return reordered


@dataclass
class Outcome:
    """What one solver run gave: status, column values, seconds, bound and
    status line."""

    status: SolveStatus
    values: Sequence[float] | None
    seconds: float | None
    bound: float | None
    solver_status: str
    #: CBC restarted with its root cuts (:attr:`.cbc.CbcResult.restarted`).
    restarted: bool = False


def cbc_options(
    built: BuiltModel | DisjunctiveModel,
    warm: Mapping[str, int] | None,
    max_nodes: int | None = None,
    heuristics: bool = False,
) -> list[str] | None:
    """The CBC options added for ``built`` (None: CBC's defaults).

    Parameters
    ----------
    built
        The model; its formulation, the resource kinds its placeable
        tasks use and its size choose the options.
    warm
        The MIP start, task id to start (the options for a start, such
        as heuristics off, apply only with one; whether it leaves a
        placeable task out chooses some).
    max_nodes
        A node limit, if any.
    heuristics
        Keep CBC's primal heuristics on even with a MIP start.
    """
    extra = None
    if warm:
        if isinstance(built, DisjunctiveModel):
            extra = list(WITH_START_DISJUNCTIVE)
            if built.problem.num_tasks <= TUNED_MAX_TASKS:
                kinds = used_kinds(built.problem, built.domains)
                if "multiple" in kinds:
                    extra += DISJUNCTIVE_STRONG
                elif kinds == {"binary"}:
                    extra += BINARY_STRONG
        else:
            extra = list(WITH_START)
            kinds = used_kinds(built.problem, built.domains)
            tuned = (
                built.problem.num_tasks <= TUNED_MAX_TASKS
                and built.program.num_rows < LARGE_ROWS
            )
            if kinds == {"consumable"}:
                extra += CONSUMABLES_ONLY
            elif (
                "consumable" in kinds
                and tuned
                and all(
                    task.id in warm
                    for task in built.problem.tasks
                    if built.vars.placeable(task.id)
                )
            ):
                extra += CONSUMABLES_AND_SHARED
            elif "multiple" in kinds and "consumable" not in kinds and tuned:
                extra += MULTIPLE_TIME_INDEXED
    program = built.program
    if (
        not isinstance(built, DisjunctiveModel)
        and program.num_rows >= LARGE_ROWS
    ):
        extra = [*(extra or ()), *LARGE]
    if isinstance(built, DisjunctiveModel) and built.cbc_options:
        extra = [*(extra or ()), *built.cbc_options]
    if max_nodes is not None:
        extra = [*(extra or ()), f"maxNodes {max_nodes}"]
    if heuristics and extra:
        extra = [option for option in extra if option not in WITH_START]
    return extra


def run_cbc(
    built: BuiltModel | DisjunctiveModel,
    time_limit: float | None,
    threads: int,
    seed: int,
    warm: dict[str, int] | None,
    max_nodes: int | None = None,
    heuristics: bool = False,
) -> Outcome:
    """Run CBC on ``built`` from the MIP start ``warm``, with the
    options its formulation and size call for (:func:`cbc_options`),
    and read its answer."""
    start = None
    extra = cbc_options(built, warm, max_nodes, heuristics)
    if warm:
        warm = in_symmetry_order(built.constraints.twins, warm)
        start = built.vars.initial(warm, built.program.num_columns)
    program = built.program
    incumbent = None if start is None else program.value(start)
    run = WatchedCbcRun(
        constant=program.constant,
        incumbent=incumbent,
        time_limit=time_limit,
        threads=threads,
        seed=seed,
        extra=extra,
    )
    result = run.solve(built.program, start)
    notes = [result.solver_status]
    if result.values is not None and not _integral(built.program, result):
        # Seen on large models stopped during root cuts: CBC wrote its LP
        # relaxation and called it optimal. Not a solution; never decoded.
        notes.append("fractional values refused")
        result.status, result.values = SolveStatus.UNKNOWN, None
    if result.completed is not None:
        read_completed(program, result, start, notes)
    if result.retried:
        notes.append("retried with preprocessing")
    if result.interrupted:
        notes.append("interrupted at the deadline")
    return Outcome(
        result.status,
        result.values,
        result.seconds,
        result.bound,
        "; ".join(notes),
        result.restarted,
    )


def _integral(program: Program, result: CbcResult) -> bool:
    """True if every integer column of the result has an integer value."""
    values = result.values or []
    return all(
        abs(value - round(value)) <= 1e-6
        for value, integer in zip(values, program.integer, strict=True)
        if integer
    )


def _run_highs(
    built: BuiltModel | DisjunctiveModel,
    time_limit: float | None,
    threads: int,
    seed: int,
) -> Outcome:
    import pulp

    if not pulp.HiGHS().available():
        raise SolverError(
            "HiGHS is not installed: pip install 'fsw-scheduler[highs]'"
        )
    lp, columns = built.program.to_pulp()
    backend = pulp.HiGHS(
        msg=False,
        threads=threads,
        timeLimit=time_limit,
        gapRel=0.0,
        gapAbs=ABS_GAP,
        random_seed=seed,
    )
    began = time.perf_counter()
    try:
        with _stdout_to_stderr():
            lp.solve(backend)
    except pulp.PulpSolverError as error:
        raise SolverError(f"highs failed: {error}") from error
    status = _pulp_status(lp)
    values = None
    if status.has_plan:
        # PuLP leaves out a column in no row and not in the objective:
        # any value in its bounds is optimal, and the lower one is valid.
        program = built.program
        values = [
            program.lower[col] if column.varValue is None else column.varValue
            for col, column in enumerate(columns)
        ]
    return Outcome(
        status,
        values,
        time.perf_counter() - began,
        _highs_bound(lp),
        pulp.LpStatus.get(lp.status, "?") + f"/{lp.sol_status}",
    )


def solve_ilp(
    problem: Problem,
    solver: str = "cbc",
    *,
    time_limit: float | None = None,
    threads: int = 1,
    seed: int = 0,
    warm: dict[str, int] | None = None,
    domains: dict[str, Domain] | None = None,
    formulation: str = "auto",
    max_nodes: int | None = None,
    heuristics: bool = False,
    stability: Stability | None = None,
    candidates: dict[str, list[int]] | None = None,
) -> Plan:
    """Build and solve the ILP of ``problem``.

    Parameters
    ----------
    problem
        A validated problem.
    solver
        ``cbc`` (default) or ``highs``.
    time_limit
        Seconds for the whole call, model building included (the solver
        gets what is left, and is not started when nothing is); at the
        best plan found is returned with status ``feasible``, or status
        ``unknown`` if none was found.
    threads
        Solver threads; 1 keeps results reproducible.
    seed
        Solver random seed.
    warm
        Task id to start time of a known plan, used as a MIP start (CBC).
    domains
        Start domains to model (default: :func:`start_domains`). Narrower
        domains must keep at least one optimal plan.
    formulation
        ``time-indexed`` (this package), ``disjunctive``
        (:mod:`fsw_scheduler.solving.ilp.disjunctive`, for problems without
        consumables in use) or
        ``auto`` (default): the one
        :func:`fsw_scheduler.solving.ilp.disjunctive.rule.pick` picks.
    max_nodes
        CBC stops after this many search nodes (status ``feasible`` with
        the best plan found, "Stopped on iterations" in
        ``solver_status``): a
        limit that, unlike time, gives the same answer on every machine.
        HiGHS ignores it.
    heuristics
        Keep CBC's primal heuristics on even with a MIP start (they are
        off then by default, :data:`~.progress.WITH_START`): for a short
        search whose point is a better plan.
    stability
        The previous starts and the price of moving them
        (:mod:`fsw_scheduler.model.stability`): the move term
        (:mod:`.moves`) joins the objective of either formulation, and
        the plan's objective reports ``moves``. Default: none.
    candidates
        Candidate starts of some tasks, for the time-indexed model
        (:class:`BuiltModel`; the disjunctive one ignores them): its
        answer is then the best plan with those starts, and ``optimal``
        says only that. Default: every start of each domain.

    Returns
    -------
    Plan
        With ``stats`` filled; without ``why`` (see
        :mod:`fsw_scheduler.analysis.explain`).
    """
    if solver not in SOLVERS:
        raise SolverError(f"unknown solver {solver!r} (choose from {SOLVERS})")
    began = time.perf_counter()
    if domains is None:
        domains = start_domains(problem)
    if formulation == "auto":
        formulation = pick(problem, domains)
        switch = (
            switch_nodes(problem, domains, TUNED_MAX_TASKS)
            if formulation == "disjunctive" and solver == "cbc"
            else None
        )
        if switch is not None and (max_nodes is None or max_nodes > switch):
            return _switching(
                problem,
                switch,
                time_limit=time_limit,
                threads=threads,
                seed=seed,
                warm=warm,
                domains=domains,
                max_nodes=max_nodes,
                heuristics=heuristics,
                stability=stability,
                candidates=candidates,
            )
    elif formulation not in FORMULATIONS:
        raise SolverError(
            f"unknown formulation {formulation!r} (choose from "
            f"{FORMULATIONS} or 'auto')"
        )
    elif formulation == "disjunctive" and "consumable" in used_kinds(
        problem, domains
    ):
        raise SolverError("the disjunctive model has no consumables")
    if time_limit is not None and formulation == "time-indexed":
        columns = start_count(domains)
        if BUILD_S_PER_COLUMN * columns > time_limit:
            # Building alone would overrun the limit (200 tasks at
            # H = 1440: 158 000 columns, 2.9 s).
            return _without_plan(
                problem,
                SolveStatus.UNKNOWN,
                dict(
                    solver=solver,
                    time_limit_s=time_limit,
                    solver_status=f"time limit too short to build a model "
                    f"of {columns} columns",
                ),
                began,
            )
    if candidates and warm:
        candidates = with_starts(candidates, warm, domains)
    built: BuiltModel | DisjunctiveModel = (
        BuiltModel(problem, domains, stability, candidates)
        if formulation == "time-indexed"
        else DisjunctiveModel(problem, domains, stability)
    )
    built_at = time.perf_counter()
    impossible = [
        task.id
        for task in problem.tasks
        if problem.required(task) and not built.vars.placeable(task.id)
    ] + impossible_groups(problem, built.vars)
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
    if not built.vars.num_placeable:
        plan = built.decode(SolveStatus.OPTIMAL, [])
        return plan.replace(
            stats=SolverStats(
                **stats,
                wall_s=time.perf_counter() - began,
                solver_status="trivial",
            )
        )
    solver_limit = time_limit
    if time_limit is not None:
        # The limit is the whole call's: building took some of it, and
        # reading the solution back and CBC's coarse clock need a margin.
        left = time_limit - (built_at - began)
        solver_limit = max(left - min(0.25, 0.1 * left), 0.0)
    if solver_limit is not None and solver_limit < MIN_CBC_S:
        outcome = Outcome(
            SolveStatus.UNKNOWN,
            None,
            0.0,
            None,
            "time limit spent before the solver started",
        )
    elif solver == "cbc":
        outcome = run_cbc(
            built, solver_limit, threads, seed, warm, max_nodes, heuristics
        )
    else:
        outcome = _run_highs(built, solver_limit, threads, seed)
    call = time.perf_counter() - built_at
    solve_s = outcome.seconds if outcome.seconds is not None else call
    stats.update(
        solve_s=solve_s,
        overhead_s=max(call - solve_s, 0.0),
        solver_status=outcome.solver_status
        + ("; disjunctive model" if formulation == "disjunctive" else ""),
    )
    if not outcome.status.has_plan or outcome.values is None:
        stats.update(bound=outcome.bound)
        status = outcome.status
        if status.has_plan:
            status = SolveStatus.UNKNOWN
        return _without_plan(problem, status, stats, began)
    plan = built.decode(outcome.status, outcome.values)
    bound = outcome.bound
    if outcome.status is SolveStatus.OPTIMAL and plan.objective:
        bound = plan.objective.total
    return plan.replace(
        stats=SolverStats(
            **stats, bound=bound, wall_s=time.perf_counter() - began
        )
    )


def _switching(
    problem: Problem,
    switch: int,
    *,
    time_limit: float | None,
    warm: dict[str, int] | None,
    domains: dict[str, Domain],
    max_nodes: int | None,
    **options: Any,
) -> Plan:
    """The disjunctive model for ``switch`` nodes, then, if that proved
    nothing, the time-indexed model from its best plan in what is left
    of ``time_limit`` (:func:`~.disjunctive.rule.switch_nodes` says
    why). A run stopped by time is the answer as it is: the switch is on
    nodes only, so the same on every machine.

    The answer is the time-indexed run's, or the disjunctive run's plan
    when the second run found none; its bound is the higher of the two
    runs' and its status line says both.
    """
    began = time.perf_counter()
    first = solve_ilp(
        problem,
        time_limit=time_limit,
        warm=warm,
        domains=domains,
        formulation="disjunctive",
        max_nodes=switch,
        **options,
    )
    said = first.stats.solver_status if first.stats else ""
    if not stopped_on_nodes(said):
        return first
    left = (
        None
        if time_limit is None
        else time_limit - (time.perf_counter() - began)
    )
    second = solve_ilp(
        problem,
        time_limit=left,
        warm=first.starts() if first.status.has_plan else warm,
        domains=domains,
        formulation="time-indexed",
        max_nodes=max_nodes,
        **options,
    )
    answer = second
    if first.status.has_plan and (
        not second.status.has_plan
        or second.objective is None
        or first.objective is None
        or first.objective.total < second.objective.total
    ):
        answer = first.replace(status=SolveStatus.FEASIBLE)
    one, two = first.stats, second.stats
    if one is None or two is None:
        return answer
    bound = two.bound
    if answer.status is not SolveStatus.OPTIMAL:
        bound = higher(bound, one.bound)
    return answer.replace(
        stats=msgspec.structs.replace(
            two,
            build_s=one.build_s + two.build_s,
            solve_s=one.solve_s + two.solve_s,
            overhead_s=one.overhead_s + two.overhead_s,
            wall_s=time.perf_counter() - began,
            bound=bound,
            time_limit_s=time_limit,
            # Not the first run's own words: "Stopped on iterations"
            # would read as this answer's (stats.stopped_on_nodes).
            solver_status=f"disjunctive model unproved after {switch} "
            f"nodes; the time-indexed model from its plan: "
            f"{two.solver_status}",
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
