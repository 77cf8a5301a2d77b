"""A bound for large parts with consumables: the disjunctive model with
the kept-set relaxation's level rows.

The kept-set bound (:func:`~fsw_scheduler.analysis.bounds.kept_set_bound`)
keeps each consumable's relaxed level rows and ignores binary and
multiple resources; on parts where those resources decide what is left
out it is far below the optimum (the large suite's broad problems: 0.1 M
against 3 M). The disjunctive model
(:mod:`fsw_scheduler.solving.ilp.disjunctive`) is exact for binary and
multiple resources and has no consumables. Together they relax the
whole part:

* the part without its consumables, in the disjunctive model (a few
  columns per task: its root LP takes milliseconds where the
  time-indexed model's took 20 s on 29 tasks over H = 1440);
* plus, over its "scheduled" binaries, the kept-set relaxation's level
  rows (consumers at their latest starts, generators at their earliest:
  every valid plan's kept set satisfies them).

Every plan of the part is a solution of this program with the same
objective, so CBC's bound on it bounds the part (:func:`relaxed_bound`).
When CBC proves the program's optimum and that plan passes the checker
on the real part (its consumables included), it is optimal there too.

When the proved optimum breaks a consumable and nothing else, the level
at the units where it first and most went below zero joins the program,
read on the start columns (:meth:`RelaxedModel._timed_level_rows`: a
binary per task that may or may not be over, or started, by then), and
CBC solves it again (:func:`relaxed_bound`, at most
:data:`MAX_LEVEL_ROUNDS` times): the rows hold for every plan, so each
optimum still bounds the part, and that plan can no longer break the
level there.
"""

from __future__ import annotations

import functools
import time
from typing import TYPE_CHECKING, NamedTuple

import msgspec

from ..analysis.bounds import KeptSetProof, better_start
from ..analysis.check import check_plan
from ..analysis.keptset import level_rows
from ..model.levels import resource_profiles
from ..model.plan import Plan, SolverStats, SolveStatus
from .confirm import confirm_limit, confirmed
from .ilp.cbclog import claimed_optimal
from .ilp.decode import Formulation
from .ilp.disjunctive.blocks import modelled
from .ilp.disjunctive.constraints import Constraints
from .ilp.disjunctive.model import DisjunctiveModel
from .ilp.disjunctive.objective import objective
from .ilp.disjunctive.rule import used_kinds
from .ilp.disjunctive.variables import Variables
from .ilp.model import run_cbc
from .ilp.program import GE, LE
from .stats import higher

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ..analysis.domains import Domain
    from ..model.problem import Problem
    from .ilp.program import Program, Terms


class RelaxedAnswer(NamedTuple):
    """What the relaxation says of a part.

    Attributes
    ----------
    bound
        A lower bound on the objective of every plan of the part within
        the domains given (None when CBC gave none).
    plan
        The relaxation's optimum when CBC proved it and it is a valid
        plan of the part (then optimal for the part), else None.
    better
        When nothing is proved: a valid plan of the part better than the
        incumbent, if one was found: CBC's best solution of the
        relaxation, or when that breaks a consumable, its kept set
        list-scheduled.
    said
        CBC's status line.
    levels
        The units whose levels were written on the starts (the next run
        of the relaxation over the same or narrower domains starts with
        them).
    """

    bound: float | None
    plan: Plan | None
    better: Plan | None
    said: str
    levels: tuple[int, ...] = ()


def applies(problem: Problem, domains: dict[str, Domain]) -> bool:
    """True if the relaxation can be built for ``problem`` and says more
    than the kept-set bound: a consumable and a binary or multiple
    resource in use, and the binary windows and capacity steps in use few
    enough for the disjunctive model's blocks (:mod:`.ilp.disjunctive.
    blocks`: it reads one capacity per resource). Alternatives are the
    model's group rows; the level rows bind every plan, groups or not.
    Where the kept-set relaxation gives no bound (groups: it prices tasks
    one by one), this is a large part's only one: on the large suite's
    problems given three groups each (20 s), seed 72: 5 of 12 proved
    against 1 without it (CP-SAT 4), seed 73: 6 against 2 (CP-SAT 7)."""
    kinds = used_kinds(problem, domains)
    if "consumable" not in kinds or kinds == {"consumable"}:
        # Without a binary or multiple resource in use the relaxation is
        # the kept-set relaxation's LP, weaker than its search.
        return False
    return modelled(without_consumables(problem), domains) is not None


def without_consumables(problem: Problem) -> Problem:
    """``problem`` with its consumables and every use of them removed."""
    consumables = set(problem.resources.consumable)
    return problem.replace(
        tasks=tuple(
            msgspec.structs.replace(
                task,
                uses={
                    name: amount
                    for name, amount in task.uses.items()
                    if name not in consumables
                },
            )
            for task in problem.tasks
        ),
        resources=msgspec.structs.replace(problem.resources, consumable={}),
    )


#: CBC options of :class:`RelaxedModel` with ``probing``: fixing the
#: order binaries that a "scheduled" binary or a start bound implies cut
#: the nodes to prove the large suite's relaxations 10-25 fold and CBC's
#: time 1.7-2 fold (seed 71's b30-h1440: 4,291 nodes and 3.0 s to 173
#: and 1.8 s; its f30-h1440 15.3 to 8.1 s; seed 73's f45-h1440 7.7 to
#: 4.2 s), but each node costs more: 500 nodes from a poor start plan
#: over wide domains did not end in 10 s (seed 73's b45-h1440, loaded
#: machine), where without probing they gave a better plan in 5 s.
PROBING = ("probing on",)


class _Levelled(Variables):
    """The disjunctive variables, and the columns of the timed level rows
    with how each takes its value from a MIP start's starts."""

    def __init__(
        self,
        program: Program,
        problem: Problem,
        domains: dict[str, Domain],
    ) -> None:
        super().__init__(program, problem, domains)
        #: Column, and its value from the start and "scheduled" values.
        self.fills: list[tuple[int, Callable[[list[float]], float]]] = []

    def initial(self, starts: dict[str, int], columns: int) -> list[float]:
        """As :meth:`Variables.initial`, the level rows' columns filled."""
        values = super().initial(starts, columns)
        for column, fill in self.fills:
            values[column] = fill(values)
        return values


class RelaxedModel(DisjunctiveModel):
    """The disjunctive model of ``problem`` without its consumables, with
    the kept-set relaxation's level rows on its "scheduled" binaries, and
    the levels at ``checkpoints`` on its start columns.

    Parameters
    ----------
    problem
        The part, consumables included (:func:`applies`).
    domains
        Its start domains (narrowed ones bound every plan within them).
    probing
        CBC's probing on (its other cuts stay off; :data:`PROBING`).
    checkpoints
        Units at whose end each consumable's level is written on the
        starts (:meth:`_timed_level_rows`).
    """

    vars: _Levelled

    def __init__(
        self,
        problem: Problem,
        domains: dict[str, Domain],
        *,
        probing: bool = False,
        checkpoints: Sequence[int] = (),
    ) -> None:
        original = problem
        if probing:
            self.cbc_options = PROBING

        def constraints(
            program: Program, stripped: Problem, variables: Variables
        ) -> Constraints:
            return _Apart(program, stripped, variables, original)

        stripped = without_consumables(problem)
        # Windows and capacity steps are held by pinned blocks, as in the
        # disjunctive model (applies() has checked that they can be).
        wide = modelled(stripped, domains)
        assert wide is not None, "the relaxation applies (applies())"
        model_problem, model_domains = wide
        Formulation.__init__(
            self,
            model_problem,
            dict(model_domains),
            _Levelled,
            constraints,
            objective,
        )
        self.problem, self.domains = stripped, domains
        placeable = [t for t in problem.tasks if not domains[t.id].empty]
        uses, limits = level_rows(problem, domains, placeable)
        for row, limit in enumerate(limits):
            self.program.add_row(
                {
                    self.vars.scheduled(task.id): uses[task.id][row]
                    for task in placeable
                },
                LE,
                limit,
            )
        # Net outside change before each unit, per consumable: read once
        # for all the checkpoints.
        changed = (
            {
                name: problem.resources.external_before(
                    name, problem.start, problem.horizon
                )
                for name in problem.resources.initial_levels
            }
            if checkpoints
            else {}
        )
        for point in sorted(set(checkpoints)):
            self._timed_level_rows(problem, domains, point, changed)

    def _timed_level_rows(
        self,
        problem: Problem,
        domains: dict[str, Domain],
        point: int,
        changed: dict[str, list[float]],
    ) -> None:
        """Each consumable's level at the end of unit ``point``, on the
        start columns: ``sum_consumers w - sum_generators v <= initial +
        external charge up to point``.

        ``w`` is a consumer's use by then, ``a min(n, max(0, point + 1 -
        s))`` when kept: ``a n`` for one that is always over by then;
        else ``w >= a (point + 1 - s)`` and, when it may be over, a
        binary ``b`` ("over": ``s <= point + 1 - n``; ``b = 0`` forces
        ``s >= point + 2 - n``) with ``w >= a n b`` and the first row
        relaxed by ``b``. ``v`` is a generator's charge by then, at most
        ``g n`` and ``g (point + 1 - s)``, and 0 unless a binary
        "started" (``s <= point``) is set. Both rows hold with ``y = 0``
        (``w = v = 0``). The values of a plan satisfy every row (``w``,
        ``v`` its true use and charge, ``b`` and "started" as they are),
        so the rows cut off no plan: the sum over-counts the level only
        where a capacity (``max``) would have lost charge. ``changed`` is
        each consumable's net outside change before each unit (its
        external profile summed).
        """
        program = self.program
        for name, initial in problem.resources.initial_levels.items():
            net = changed[name]
            charge = net[min(point + 1 - problem.start, len(net) - 1)]
            terms: Terms = {}
            for task in problem.tasks:
                amount = task.uses.get(name, 0)
                domain = domains[task.id]
                if not amount or domain.empty or domain.earliest > point:
                    continue
                if amount > 0:
                    self._consumer(terms, task.id, task.length, amount, point)
                else:
                    self._generator(
                        terms, task.id, task.length, -amount, point
                    )
            if terms:
                program.add_row(terms, LE, initial + charge)

    def _consumer(
        self, terms: Terms, name: str, length: int, amount: float, point: int
    ) -> None:
        """A consumer's use by the end of ``point`` into ``terms``."""
        program, vars_ = self.program, self.vars
        domain = self.domains[name]
        low, high = domain.earliest, domain.latest
        start, kept = vars_.start(name), vars_.scheduled(name)
        if high + length <= point + 1:  # always over by then
            terms[kept] = terms.get(kept, 0.0) + amount * length
            return
        use = program.add_column(0.0)
        terms[use] = 1.0
        # w >= a (point + 1 - s) - a (point + 1 - low) (1 - y) - a D b
        partial: Terms = {
            start: -amount,
            kept: amount * (point + 1 - low),
            use: -1.0,
        }
        over_by = point + 1 - length  # "over" iff s <= over_by
        if low <= over_by:
            (over,) = program.add_binaries(1)
            partial[over] = -amount * (over_by - low)
            # b = 0 forces s >= over_by + 1
            program.add_row(
                {start: 1.0, over: float(over_by + 1 - low)}, GE, over_by + 1
            )
            # w >= a n (b + y - 1)
            program.add_row(
                {over: amount * length, kept: amount * length, use: -1.0},
                LE,
                amount * length,
            )
            vars_.fills.append(
                (over, functools.partial(_by, start=start, time=over_by))
            )
        program.add_row(partial, LE, -amount * low)
        vars_.fills.append(
            (
                use,
                functools.partial(
                    _run_by,
                    task=(start, kept, length),
                    rate=amount,
                    time=point,
                ),
            )
        )

    def _generator(
        self, terms: Terms, name: str, length: int, rate: float, point: int
    ) -> None:
        """A generator's charge by the end of ``point`` into ``terms``."""
        program, vars_ = self.program, self.vars
        domain = self.domains[name]
        low, high = domain.earliest, domain.latest
        start, kept = vars_.start(name), vars_.scheduled(name)
        charge = program.add_column(0.0)
        terms[charge] = -1.0
        # v <= g n y
        program.add_row({charge: 1.0, kept: -rate * length}, LE, 0.0)
        if high <= point:  # always started by then
            # v <= g (point + 1 - s)
            program.add_row({charge: 1.0, start: rate}, LE, rate * (point + 1))
        else:
            (started,) = program.add_binaries(1)
            # started = 0 forces s >= point + 1
            program.add_row(
                {start: 1.0, started: float(point + 1 - low)}, GE, point + 1
            )
            program.add_row({charge: 1.0, started: -rate * length}, LE, 0.0)
            # v <= g (point + 1 - s) + g (high - point - 1) (1 - started)
            program.add_row(
                {
                    charge: 1.0,
                    start: rate,
                    started: rate * (high - point - 1),
                },
                LE,
                rate * high,
            )
            vars_.fills.append(
                (started, functools.partial(_by, start=start, time=point))
            )
        vars_.fills.append(
            (
                charge,
                functools.partial(
                    _run_by, task=(start, kept, length), rate=rate, time=point
                ),
            )
        )


def _by(values: list[float], *, start: int, time: int) -> float:
    """1 if the start column's value is at most ``time``, else 0."""
    return float(values[start] <= time + 0.5)


def _run_by(
    values: list[float],
    *,
    task: tuple[int, int, int],
    rate: float,
    time: int,
) -> float:
    """``rate`` times the units a task (start column, "scheduled" column,
    length) has run by the end of ``time``, 0 when not kept."""
    start, kept, length = task
    units = min(length, max(0.0, time + 1 - values[start]))
    return rate * values[kept] * units


class _Apart(Constraints):
    """The disjunctive constraints, with identical tasks told apart by
    their consumable uses too: the symmetry rows of tasks that differ
    only there would cut the level rows' optimum off.

    Without the energy rows: in the relaxation's rounds on large parts
    they did not move the bound and slowed the rounds (orbit suite seed
    77's ob60-h2880, 20 s: 27.6 M -> 31.6 M; large suite seed 76: the
    same bounds, the same parts proved).
    """

    energy_rows = False

    def __init__(
        self,
        program: Program,
        problem: Problem,
        variables: Variables,
        original: Problem,
    ) -> None:
        super().__init__(program, problem, variables)
        # The original's uses, consumables included; a block (a task of
        # the model's problem only) has its own.
        uses = {
            task.id: tuple(sorted((k, v) for k, v in task.uses.items() if v))
            for task in (*problem.tasks, *original.tasks)
        }
        twins: list[list[str]] = []
        for group in self.twins:
            split: dict[tuple[tuple[str, float], ...], list[str]] = {}
            for name in group:
                split.setdefault(uses[name], []).append(name)
            twins += [names for names in split.values() if len(names) > 1]
        self.twins = twins
        self._twin_at = {
            name: (group_idx, position)
            for group_idx, group in enumerate(twins)
            for position, name in enumerate(group)
        }


def relaxed_bound(
    problem: Problem,
    incumbent: Plan,
    domains: dict[str, Domain],
    *,
    time_limit: float | None,
    max_nodes: int | None = None,
    probing: bool = False,
    threads: int = 1,
    seed: int = 0,
    levels: Sequence[int] = (),
    level_rounds: int | None = None,
    confirm_until: float | None = None,
) -> RelaxedAnswer:
    """CBC on :class:`RelaxedModel`, from ``incumbent``.

    Parameters
    ----------
    problem
        A part for which :func:`applies`.
    incumbent
        A valid plan of it within ``domains`` (the MIP start).
    domains
        Start domains that hold every plan at least as good as
        ``incumbent`` (:func:`~fsw_scheduler.solving.incumbent.narrow`).
    time_limit, max_nodes, probing, threads, seed
        For CBC (``probing``: :class:`RelaxedModel`'s).
    levels
        Units whose levels are written on the starts from the first run
        (:class:`RelaxedModel`'s ``checkpoints``); while CBC proves an
        optimum that breaks a consumable and only that, the units where
        it first and most went below zero join them (:func:`lowest_units`;
        with more than :data:`SMALL_LEVEL_ROUNDS` rounds also its last
        and :data:`SPREAD` more across each stretch) and CBC runs again,
        at most ``level_rounds`` times (:data:`MAX_LEVEL_ROUNDS` by
        default).
    confirm_until
        :func:`time.perf_counter` value by which a run confirming an
        optimum CBC claimed after its restart
        (:func:`~.confirm.confirmed`) must end, when later than
        ``time_limit`` allows (a caller's overtime).

    Returns
    -------
    RelaxedAnswer
        The bound, and the part's optimum when the relaxation's is valid.
    """
    began = time.perf_counter()
    checkpoints = sorted(set(levels))
    best: float | None = None  # every run's bound holds
    rounds = 0
    if level_rounds is None:
        level_rounds = MAX_LEVEL_ROUNDS
    spread = SPREAD if level_rounds > SMALL_LEVEL_ROUNDS else 0
    while True:
        built = RelaxedModel(
            problem, domains, probing=probing, checkpoints=checkpoints
        )
        built_at = time.perf_counter()
        limit = None
        if time_limit is not None:
            limit = max(0.0, time_limit - (time.perf_counter() - began))
        outcome = run_cbc(
            built, limit, threads, seed, incumbent.starts(), max_nodes
        )
        if (
            outcome.restarted
            and outcome.values is not None
            and claimed_optimal(outcome.solver_status)
        ):
            # Its bound stays in the confirmed answer's (the higher).
            outcome = confirmed(
                built,
                outcome,
                confirm_limit(began, time_limit, confirm_until),
                threads,
                seed,
                max_nodes,
            )
        best = higher(best, outcome.bound)
        if outcome.values is None or not outcome.status.has_plan:
            return RelaxedAnswer(
                best, None, None, outcome.solver_status, tuple(checkpoints)
            )
        relaxed = built.decode(outcome.status, outcome.values)
        proved = outcome.status is SolveStatus.OPTIMAL
        if proved and relaxed.objective is not None:
            best = higher(best, float(relaxed.objective.total))
        report = check_plan(
            problem,
            relaxed.replace(objective=None, status=SolveStatus.FEASIBLE),
        )
        if (
            not proved
            or report.ok
            or rounds >= level_rounds
            or any(v.rule != "consumable" for v in report.violations)
            or (
                time_limit is not None
                and time.perf_counter() - began >= time_limit
            )
        ):
            break
        below = sorted(
            set(lowest_units(problem, relaxed, spread)) - set(checkpoints)
        )
        if not below:
            break
        # The optimum breaks a level only: the level there joins the
        # program, and CBC solves it again.
        checkpoints = sorted({*checkpoints, *below})
        rounds += 1
    bound = best
    written = (
        f" (the levels at {len(checkpoints)} units written on the starts)"
        if checkpoints
        else ""
    )
    if proved and report.ok and report.objective is not None:
        said = (
            "the disjunctive relaxation's optimum is a valid plan"
            f"{written}: " + outcome.solver_status
        )
        stats = SolverStats(
            solver="cbc-relaxed",
            build_s=built_at - began,
            solve_s=outcome.seconds or 0.0,
            wall_s=time.perf_counter() - began,
            num_variables=built.num_variables,
            num_constraints=built.num_constraints,
            bound=bound,
            solver_status=said,
            time_limit_s=time_limit,
        )
        optimal = relaxed.replace(
            status=SolveStatus.OPTIMAL, objective=report.objective, stats=stats
        )
        return RelaxedAnswer(bound, optimal, None, said, tuple(checkpoints))
    # The relaxation's solution, if valid, and its kept set list-scheduled
    # (which often leaves out as little as the optimum: the large suite's
    # b30-h1440 of seed 53, 2,279,897 against CP-SAT's optimum 2,279,283,
    # where 20 s of search had found 2,286,507): the better of them.
    candidates = [
        better_start(
            problem,
            incumbent,
            KeptSetProof(None, None, kept=frozenset(relaxed.starts())),
        )
    ]
    if report.ok and report.objective is not None:
        candidates.append(
            relaxed.replace(
                status=SolveStatus.FEASIBLE, objective=report.objective
            )
        )
    better = min(
        (
            plan
            for plan in candidates
            if plan is not None
            and plan.objective is not None
            and incumbent.objective is not None
            and plan.objective.total < incumbent.objective.total
        ),
        key=lambda plan: plan.objective.total if plan.objective else 0,
        default=None,
    )
    return RelaxedAnswer(
        bound,
        None,
        better,
        outcome.solver_status + written,
        tuple(checkpoints),
    )


def lowest_units(problem: Problem, plan: Plan, spread: int = 0) -> list[int]:
    """Units at whose end a consumable's level is below zero in ``plan``:
    the first and the lowest of each stretch below zero, of each
    consumable (the level rows there cut the most off); with ``spread``,
    also the stretch's last unit and one every ``len // spread`` units
    across it (a level written at one unit only moves the next optimum's
    dip a unit or two)."""
    found: set[int] = set()
    levels = resource_profiles(problem, plan)
    for name in problem.resources.consumable:
        stretch: list[int] = []
        for index, level in enumerate([*levels[name], 0.0]):
            if level < -_EPS:
                stretch.append(index)
                continue
            if stretch:
                lowest = min(stretch, key=lambda i: (levels[name][i], i))
                picked = {stretch[0], lowest}
                if spread:
                    picked.add(stretch[-1])
                    picked.update(stretch[:: max(1, len(stretch) // spread)])
                found.update(problem.start + i for i in picked)
                stretch = []
    return sorted(found)


#: Levels this far below zero count as below (float amounts).
_EPS = 1e-9

#: Times the relaxation is solved again with the levels where its optimum
#: broke a consumable (:func:`relaxed_bound`): for a part whose
#: time-indexed model is too large for CBC (seed 62's f30-h2880: one run
#: again proved it, 2.1 s).
MAX_LEVEL_ROUNDS = 8
#: The same for a small part, whose time-indexed model CBC proves in about
#: a second (:data:`~fsw_scheduler.solving.incumbent.RELAXED_COLUMNS`),
#: and its rounds end once one wrote levels
#: (:func:`~fsw_scheduler.solving.rounds.rounds`). On the 15-task ``all``
#: problems where levels were written (paper seeds 102, 106, 107), the
#: product's solve against the code without levels: 2.34 -> 0.71 s
#: (102's c15-all-5, CP-SAT 0.025 s) and 0.79 -> 0.37 s proved by one run
#: with levels; 1.0 -> 1.34, 2.95 -> 3.7, 0.12 -> 0.31 and 2.05 -> 2.36 s
#: where it did not prove and the time-indexed model did. With 8 runs
#: those took 2.7 and 5.9 s (the levels moved the optimum a unit or two
#: each run).
SMALL_LEVEL_ROUNDS = 1

#: With more rounds than :data:`SMALL_LEVEL_ROUNDS`, the levels written
#: at each round spread across every stretch below zero
#: (:func:`lowest_units`), not only its first and lowest unit: the fresh
#: campaign's f25-h1440-1 of seed 138 (a 23-task part whose time-indexed
#: model CBC does not get through its root in 2.5 s) took ten runs of the
#: relaxation, each moving the dip by a unit or two, and was proved at
#: 9.93 s of a 30 s limit (`feasible` at 10 s, 2,012 units above); with
#: the stretch spread over four more units, at 5.7 s (at 10 s, 62-100 units
#: above). A small part's one run keeps the two units: written there, the
#: wider model cost paper seed 102's c15-all-5 its proof in that run
#: (0.78 -> 3.68 s).
SPREAD = 4

#: Share of the time left that the relaxation may take before the rest
#: of a part's solve, and its search nodes (a node limit: the same bound
#: on every machine).
SHARE = 0.3
NODES = 500

#: Seconds left below which the relaxation is not run: its share of a
#: shorter limit rarely holds its 500 nodes on 45-60 tasks, and a run
#: stopped by time returns no plan (a 60-task part under a 3 s limit
#: then lost the search's only improvement).
MIN_LEFT_S = 5.0

#: A fresh large part's own minimum (:func:`fresh_min_left`): this much
#: per task, at least :data:`MIN_LEFT_FLOOR_S`, at most
#: :data:`MIN_LEFT_S`. The relaxation's 500 nodes cost in proportion to
#: the part. At a 5 s limit, on 16 fresh parts of 30-60 tasks (seeds
#: 100-101, H = 336 and 1440), it now runs for up to 55 tasks: f40-h1440
#: proved (10,731,604, where the search alone ended 1,184 above), 4
#: plans better, 3 worse by a few hundred delay units. From 1 s left for
#: every size, a 60-task part lost a whole task in some runs (3,882,555
#: -> 4,010,555: the rounds take the time its search needs).
MIN_LEFT_S_PER_TASK = 0.09
MIN_LEFT_FLOOR_S = 1.0


def fresh_min_left(problem: Problem) -> float:
    """Seconds a fresh large part needs left to run the relaxation
    (see :data:`MIN_LEFT_S_PER_TASK`)."""
    return min(
        MIN_LEFT_S,
        max(MIN_LEFT_FLOOR_S, MIN_LEFT_S_PER_TASK * problem.num_tasks),
    )


def relaxable(
    run: Callable[..., Plan],
    problem: Problem,
    domains: dict[str, Domain],
    left: float | None,
    min_left: float = MIN_LEFT_S,
) -> bool:
    """True if the relaxation is run for ``problem`` with ``left`` seconds
    left (None: no limit): CBC is the solver (``run``'s), at least
    ``min_left`` (:data:`MIN_LEFT_S`) are left, and :func:`applies`."""
    solver = "cbc"
    if isinstance(run, functools.partial):
        solver = run.keywords.get("solver", "cbc")
    return (
        solver == "cbc"
        and (left is None or left >= min_left)
        and applies(problem, domains)
    )


def around(
    problem: Problem,
    start: Plan,
    narrowed: dict[str, Domain],
    run: Callable[..., Plan],
    limit: float | None,
    nodes: int | None = NODES,
    *,
    probing: bool = False,
    levels: Sequence[int] = (),
    level_rounds: int | None = None,
    confirm_until: float | None = None,
) -> RelaxedAnswer:
    """:func:`relaxed_bound` from ``start`` over ``narrowed`` (the domains
    every plan at least as good keeps), with ``nodes`` nodes
    (:data:`NODES`; None: no node limit), ``probing``, the ``levels`` a
    run before wrote and at most ``level_rounds`` runs again
    (:func:`relaxed_bound`), and at most ``limit`` seconds (a run
    confirming a claimed optimum to ``confirm_until``), with ``run``'s
    threads and seed. Its bound
    is dropped when above ``start`` (it then bounds nothing)."""
    settings = run.keywords if isinstance(run, functools.partial) else {}
    answer = relaxed_bound(
        problem,
        start,
        narrowed,
        time_limit=limit,
        max_nodes=nodes,
        probing=probing,
        levels=levels,
        level_rounds=level_rounds,
        confirm_until=confirm_until,
        threads=settings.get("threads", 1),
        seed=settings.get("seed", 0),
    )
    if (
        answer.bound is not None
        and start.objective is not None
        and answer.bound > start.objective.total + 0.5
    ):
        answer = answer._replace(bound=None)
    return answer
