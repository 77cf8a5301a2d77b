"""Pairs of tasks that no plan holds together (pure).

Scheduling a task schedules its *companions*: the tasks its precedences
need, directly or through one another
(:func:`~fsw_scheduler.analysis.proofs.precedence_needs`). Tight
precedences fix the start differences inside each tight-connected block
of scheduled tasks. :func:`~fsw_scheduler.analysis.proofs.
block_conflicts` finds the tasks whose own companions cannot hold; this
module finds the *pairs* of tasks, each possible alone, whose companions
cannot hold together: the blocks they form at once fix two users of a
binary resource so that they overlap, users of a multiple resource so
that they exceed its largest capacity, or contradict a precedence.

Broad seed 130's b15-multiple-4 (tools/bench): T000 starts right after
T007 and T014 end and one unit after T004 starts, T008 ten units after
T007 ends; with both T000 and T008 scheduled, T000, T004 and T008 draw
136 of the power's 120 at once. No plan holds T000 and T008 together,
whatever the windows, and CP-SAT proves the optimum (T008 left out) in
37 ms. The LP relaxation of either ILP keeps both, each at a fraction,
and CBC searched 10 s without a bound above the plan's delays alone. So
``y_a + y_b <= 1`` is written in both models, and the kept-set search
never keeps both (:mod:`.keptset`).

Found without a solver, from the precedences and uses alone: only pairs
whose companions touch through a tight precedence are tried, each on
the problem cut down to the pair's companions (a try reads their
precedences only), at most :data:`MAX_TRIES` of them, and at most
:data:`MAX_PAIRS` are kept: a root with 300 tight successors on one
camera makes 44,850 exclusive pairs, which the cap holds to a bounded
number of rows found in a bounded time.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .proofs import block_conflict, block_conflicts, precedence_needs, reach

if TYPE_CHECKING:
    from ..model.problem import Precedence, Problem

#: Pairs tried at most per problem (each a sweep of a few blocks, about
#: 15 us on the problem cut down to the pair): a problem of many tight
#: chains gives up its rest rather than its time.
MAX_TRIES = 5_000

#: Pairs kept at most per problem (each a row of the models).
MAX_PAIRS = 1_000

#: The last problem asked and its answer: the solve of one part asks for
#: it from each model it builds and each kept-set search.
_last: tuple[Problem, tuple[tuple[str, str], ...]] | None = None


def exclusive_pairs(problem: Problem) -> tuple[tuple[str, str], ...]:
    """Pairs of tasks no valid plan schedules together.

    Tasks that can never be scheduled (:func:`~.proofs.block_conflicts`)
    are left out of every pair: their start domains are empty already.
    A pair where one task needs the other is never exclusive (its
    companions are the needing task's, which hold).

    Returns
    -------
    tuple of (str, str)
        Each pair in problem task order, the pairs in that order too.
    """
    global _last
    last = _last  # one read: solves in other threads may replace it
    if last is not None and last[0] is problem:
        return last[1]
    found = _exclusive_pairs(problem)
    _last = (problem, found)
    return found


def _exclusive_pairs(problem: Problem) -> tuple[tuple[str, str], ...]:
    tight: dict[str, list[str]] = {}
    for prec in problem.precedences:
        if prec.kind == "tight":
            tight.setdefault(prec.before, []).append(prec.after)
            tight.setdefault(prec.after, []).append(prec.before)
    if not tight:
        return ()
    impossible = block_conflicts(problem)
    needs = precedence_needs(problem)
    tasks = {task.id: task for task in problem.tasks}
    order = {task.id: index for index, task in enumerate(problem.tasks)}
    position = {id(prec): k for k, prec in enumerate(problem.precedences)}
    companions = {
        name: frozenset(reach({name}, needs))
        for name in tasks
        if name not in impossible
    }
    # A pair can clash only where a tight precedence joins (or a task is
    # shared by) the two companion sets: elsewhere the blocks of the two
    # together are those of each alone, which hold.
    touching: dict[str, list[Precedence]] = {}
    for prec in problem.precedences:
        touching.setdefault(prec.before, []).append(prec)
        if prec.after != prec.before:
            touching.setdefault(prec.after, []).append(prec)
    holders: dict[str, list[str]] = {}
    for name, members in companions.items():
        for member in members:
            holders.setdefault(member, []).append(name)
    found: list[tuple[str, str]] = []
    tries = 0
    for first, members in companions.items():
        touched = set(members)
        for member in members:
            touched.update(tight.get(member, ()))
        candidates = {
            other
            for member in touched
            for other in holders.get(member, ())
            if order[other] > order[first]
        }
        for second in sorted(candidates, key=order.__getitem__):
            if second in members or first in companions[second]:
                continue
            tries += 1
            if tries > MAX_TRIES or len(found) >= MAX_PAIRS:
                return tuple(found)
            together = members | companions[second]
            # The pair's companions alone, with the precedences among
            # them: what block_conflict reads, without the rest.
            inside = {
                id(prec): prec
                for name in together
                for prec in touching.get(name, ())
                if prec.before in together and prec.after in together
            }
            local = problem.replace(
                tasks=tuple(
                    tasks[name]
                    for name in sorted(together, key=order.__getitem__)
                ),
                precedences=tuple(
                    sorted(
                        inside.values(), key=lambda prec: position[id(prec)]
                    )
                ),
            )
            if block_conflict(local, tasks, together) is not None:
                found.append((first, second))
    return tuple(found)
