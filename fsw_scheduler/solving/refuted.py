"""Kept sets the solver refutes: a higher bound, and a start plan that
keeps what the bound keeps.

The kept-set relaxation (:mod:`fsw_scheduler.analysis.bounds`) finds the
cheapest set of tasks to keep under rows that ignore time's order (every
kept task at its earliest start, energy per interval); where it keeps
more than any start plan does, either the start heuristic cannot place
that set or no plan can. :func:`refuted` asks: the set, every task of it
made mandatory and the rest left out (:func:`~fsw_scheduler.analysis.
bounds.kept_only`), goes to the cheap infeasibility proofs and then to
the solver. A plan of it is a start that keeps what the bound keeps;
a proof that it has none is a *no-good* (no plan keeps all of those
tasks while it leaves out every other task that could supply them), the
relaxation runs again without it, its bound higher, and the next set is
asked, until one has a plan, the rounds or the time run out, or the
solver cannot say.

``tools/fuzz --large`` seed 1462 (38 tasks over H = 120, three cameras,
two power lines, one of them halved for 40 units): the relaxation keeps
32 tasks, the start heuristic and 9 s of neighbourhood search 29
(267,338; CP-SAT proves 175,027, 31 kept, in 0.2 s). The 32 are refuted
in 0.15 s; the next set, 31 tasks, gets a plan in 2.4 s, CP-SAT's
optimum, and the bound rises from 159,927 to 173,014.

A proof by the cheap arguments (:func:`~fsw_scheduler.analysis.proofs.
infeasibility`) names the tasks it needs; those, with the set's supplies
(a set's no-good holds only while no supply outside it is kept), are
proved again alone and, when they are, make the no-good: far fewer tasks
than the set, so one no-good rules out many sets.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, NamedTuple

from ..analysis.bounds import KeptSetProof, kept_only, kept_set_bound, widened
from ..analysis.domains import start_count, start_domains
from ..analysis.proofs import infeasibility
from ..analysis.supply import charges_a_store
from ..model.plan import SolveStatus
from .budget import stop_at
from .incumbent import ROOT_PROBE_COLUMNS, worth_a_probe

if TYPE_CHECKING:
    from collections.abc import Callable, Set

    from ..analysis.domains import Domain
    from ..analysis.keptset import Nogood
    from ..model.plan import Plan
    from ..model.problem import Problem

#: Sets asked at most. Each costs a kept-set search (milliseconds on 60
#: tasks) and a proof or a solver run.
MAX_ROUNDS = 20

#: Share of the time left that the rounds may take, all together; each
#: solver run gets what is left of it.
SHARE = 0.35

#: Start times at most of a set alone for the solver to be asked (the
#: root probe's threshold, :data:`~fsw_scheduler.solving.incumbent.
#: ROOT_PROBE_COLUMNS`). Over long horizons a set's model is too large
#: to be decided in seconds: the large suite's b30-h2880 of seed 215
#: (a 24-task set over H = 2,880, about 48,000 start times) ran 6.2 s
#: undecided, and the part, proved in 5 s before, took 11.6 s; seed
#: 1462's sets over H = 120 have under 2,800.
SOLVER_COLUMNS = ROOT_PROBE_COLUMNS

#: Seconds at least for a solver run (CBC's start and the model's
#: reading); with less the rounds end.
MIN_RUN_S = 0.3


class Refuted(NamedTuple):
    """What the rounds of :func:`refuted` found.

    Attributes
    ----------
    plan
        A valid plan of the problem keeping the last set asked, when the
        solver found one; else None.
    proof
        The relaxation of the last round, with every no-good: its bound
        holds for every plan (its :attr:`~fsw_scheduler.analysis.bounds.
        KeptSetProof.plan`, when set, is an optimal plan: the start plan
        when no set the no-goods allow costs less).
    nogoods
        The no-goods found, for later kept-set searches.
    said
        What happened, for the status line; empty when nothing was asked.
    """

    plan: Plan | None
    proof: KeptSetProof
    nogoods: tuple[Nogood, ...]
    said: str


def refuted(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    proof: KeptSetProof,
    run: Callable[..., Plan],
    deadline: float,
    *,
    solver: bool = True,
) -> Refuted:
    """Ask the solver about the relaxation's kept sets while they keep
    more than ``start``.

    Parameters
    ----------
    problem
        A part without groups of alternatives (their options are not cut
        to a set here).
    start
        A valid plan of ``problem`` with its objective: the cutoff of the
        kept-set searches.
    domains
        The problem's start domains.
    proof
        The kept-set relaxation of ``start`` (:func:`~fsw_scheduler.
        analysis.bounds.kept_set_bound`).
    run
        The solver (:func:`~fsw_scheduler.solving.ilp.solve_ilp` with the
        caller's options); called with ``time_limit``.
    deadline
        When the caller's limit ends (:func:`time.perf_counter`).
    solver
        Whether the solver may be asked (False: the cheap proofs alone,
        the rounds ending at the first set they cannot refute).

    Returns
    -------
    Refuted
        Nothing asked (``said`` empty) when the start plan already keeps
        as much as the relaxation, or the part has groups.
    """
    if problem.alternatives:
        return Refuted(None, proof, (), "")
    now = time.perf_counter()
    end = now + SHARE * max(0.0, deadline - now)
    nogoods: list[Nogood] = []
    for _ in range(MAX_ROUNDS):
        kept = proof.kept
        if (
            kept is None
            or proof.plan is not None
            or not worth_a_probe(problem, start, proof)
        ):
            break
        left = end - time.perf_counter()
        answer = asked(
            problem, kept, run, left if solver and left >= MIN_RUN_S else None
        )
        if answer.nogood is None:
            then = (
                "a plan of it found"
                if answer.plan is not None
                else "the solver could not say"
                if answer.solved
                else ""
            )
            return Refuted(
                answer.plan,
                proof,
                tuple(nogoods),
                _said(len(nogoods), len(kept), then),
            )
        nogoods.append(answer.nogood)
        again = kept_set_bound(
            problem, start, domains, stop=stop_at(end), nogoods=nogoods
        )
        if again.bound is None:
            # The search ran out: the last bound stands.
            break
        proof = again
    return Refuted(None, proof, tuple(nogoods), _said(len(nogoods), 0, ""))


class Answer(NamedTuple):
    """What :func:`asked` learnt of a kept set.

    Attributes
    ----------
    nogood
        The choice no plan makes, when the set has no plan: a subset of
        it kept (the whole set, or the tasks a cheap proof needs and the
        set's supplies) while every other supply is left out.
    plan
        A valid plan of the problem that keeps the set, when the solver
        found one.
    solved
        Whether the solver ran (the cheap proofs said nothing).
    """

    nogood: Nogood | None
    plan: Plan | None
    solved: bool


def asked(
    problem: Problem,
    kept: frozenset[str],
    run: Callable[..., Plan],
    time_limit: float | None,
) -> Answer:
    """Whether some plan of ``problem`` keeps every task of ``kept``.

    The set alone, each task of it mandatory and the others left out
    (:func:`~fsw_scheduler.analysis.bounds.kept_only`), goes to the cheap
    proofs (:func:`_cheap_core`), then, with ``time_limit`` (None: not
    asked) and a model of at most :data:`SOLVER_COLUMNS` start times, to
    the solver. Leaving tasks out frees binary and multiple
    resources and raises every level a task only draws from, and a
    precedence to a task left out is dropped with it: so a plan keeping
    the set and no other supply, cut to the set, is a plan of the set
    alone, and a set alone without a plan is a no-good with every other
    supply as its second side.
    """
    supplies = frozenset(
        t.id for t in problem.tasks if charges_a_store(problem, t)
    )
    alone = kept_only(problem, kept)
    domains = start_domains(alone)
    cheap = _cheap_core(problem, kept, alone, domains, supplies)
    if cheap is not None:
        return Answer((cheap, supplies - cheap), None, solved=False)
    if time_limit is None or start_count(domains) > SOLVER_COLUMNS:
        return Answer(None, None, solved=False)
    answer = run(alone, time_limit=time_limit)
    if answer.status.has_plan:
        return Answer(None, widened(problem, answer), solved=True)
    if answer.status is SolveStatus.INFEASIBLE:
        return Answer((kept, supplies - kept), None, solved=True)
    return Answer(None, None, solved=True)


def _cheap_core(
    problem: Problem,
    kept: frozenset[str],
    whole: Problem,
    domains: dict[str, Domain],
    supplies: Set[str],
) -> frozenset[str] | None:
    """A subset of ``kept`` no plan keeps all of while it keeps no other
    supply, proved by the cheap arguments on ``whole`` (``kept`` alone,
    :func:`~fsw_scheduler.analysis.bounds.kept_only`, with its start
    ``domains``); None when they prove nothing of ``kept``.

    The tasks a proof names, with ``kept``'s supplies (the proof may
    lean on a consumable: a supply it dropped would lift it), are proved
    again alone; when that fails the whole set is the core.
    """
    named = infeasibility(whole, domains)
    if not named:
        return None
    core = frozenset(b.task for b in named) | (kept & supplies)
    if core < kept:
        alone = kept_only(problem, core)
        if infeasibility(alone, start_domains(alone)):
            return core
    return kept


def _said(refutations: int, size: int, then: str) -> str:
    """The status line's account of the rounds (empty when nothing was
    refuted or found)."""
    if not refutations and not then:
        return ""
    text = f"{refutations} kept set{'' if refutations == 1 else 's'} refuted"
    if then:
        text += f"; the next, of {size} tasks: {then}"
    return text
