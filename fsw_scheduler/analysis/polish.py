"""A plan's kept tasks moved earlier where that lowers its delay (pure).

The neighbourhood search improves a large plan window by window, each
window a CBC run of a fraction of a second or more; a replan has a fifth
of the limit for it, and its answers were worse than a fresh solve's by
a few hundred to a few thousand delay units on objectives of millions
(replan suite, seeds 29-35). Many of those units were single moves no
window had been given the time to find: a task that fits earlier as it
is, or once the one or two tasks in its way start right after it.

:func:`polished` makes such moves on the plan itself, with the checker
as the only judge of a move (every resource kind, resource profiles,
precedences, windows and pins, as :func:`~.check.check_plan` reads
them): for each kept task, the most delay cost first, it tries the
starts before its own where something begins or ends (and its earliest
start), earliest first:

* **shift**: the task alone at that start;
* **push**: the task there and the one or two tasks sharing a resource
  with it that are in its way started at its new end (or, for one of
  them, at the next few points after it), when what they lose is less
  than what the task gains.

A move is kept when the checker accepts the plan and its objective
falls; the sweep starts again after each kept move. Most moves tried
break a rule the moved tasks alone show (of 2,000 checks on the large
suite's f60-h1440 of seed 202, 9 passed: the others put two users on a
binary resource, a multiple one over its largest capacity, or broke a
precedence of a moved task), so those are refused before the checker
runs (:meth:`_Polish._refused`): a refusal is only ever a plan the
checker would refuse too, and every plan kept is still the checker's.
The set of kept tasks never changes (leaving out less is
:mod:`.insert`'s and the solver's business), so the plan's choice of
options stands. The work is bounded in checks (:data:`MAX_CHECKS`, and
:data:`MAX_REFUSED` moves refused before a check), not in seconds, so
the answer is the same on every machine; ``stop`` only guards a caller's
deadline. Plans whose objective prices moves (a stable replan) are not
polished: moving earlier may cost a move.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .greedy import checked_starts
from .spans import TOLERANCE

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..model.plan import Plan
    from ..model.problem import Precedence, Problem, Task
    from .domains import Domain

#: Plans checked at most: a check is 0.2-0.5 ms on 60 tasks over H =
#: 1440-2880, so at most about a second. On the replan suite's unproved
#: answers (seeds 34-35, 45-60 tasks) a polish took 95-1,249 checks.
MAX_CHECKS = 2_000
#: Moves refused before a check at most (:meth:`_Polish._refused`: tens
#: of microseconds each on 60 tasks, against a check's 0.2-0.8 ms).
MAX_REFUSED = 20_000
#: The caller's ``stop`` is asked before each check and after every this
#: many refusals.
ASK_EVERY = 100
#: Tasks in the way that a push moves at most.
MAX_PUSHED = 2
#: Later points tried for a single task in the way, past the moved
#: task's new end.
LATER_POINTS = 4


def polished(
    problem: Problem,
    plan: Plan,
    domains: dict[str, Domain],
    stop: Callable[[], bool] | None = None,
    max_checks: int = MAX_CHECKS,
) -> Plan:
    """``plan`` with its kept tasks moved earlier where that is better.

    Parameters
    ----------
    problem
        The problem ``plan`` solves.
    plan
        A plan the checker accepts, with its objective.
    domains
        The problem's start domains
        (:func:`~fsw_scheduler.analysis.domains.start_domains`).
    stop
        Asked before each check; the moves kept so far are returned once
        it says true.
    max_checks
        Plans checked at most.

    Returns
    -------
    Plan
        ``plan`` itself when no move lowers its objective (or it has no
        objective); otherwise the better plan, with the checker's
        objective and ``plan``'s status, left-out tasks and chosen
        options.
    """
    if plan.objective is None or not plan.activities:
        return plan
    return _Polish(problem, plan, domains, stop, max_checks).run()


class _Polish:
    """One polish of one plan: its starts, its best total, checks left."""

    def __init__(
        self,
        problem: Problem,
        plan: Plan,
        domains: dict[str, Domain],
        stop: Callable[[], bool] | None,
        max_checks: int,
    ) -> None:
        self.problem = problem
        self.plan = plan
        self.domains = domains
        self.stop = stop
        self.checks_left = max_checks
        self.tasks: dict[str, Task] = {t.id: t for t in problem.tasks}
        self.starts = plan.starts()
        assert plan.objective is not None
        self.best = plan.objective.total
        self.best_plan = plan
        # Which resources each task holds (binary and multiple, and what
        # it draws from a consumable): tasks in the way share one.
        self.held = {
            name: frozenset(k for k, v in task.uses.items() if v > 0)
            for name, task in self.tasks.items()
        }
        resources = problem.resources
        binary = set(resources.binary_names)
        self.binary = {name: self.held[name] & binary for name in self.tasks}
        # What a task takes of each multiple resource, and the most the
        # resource ever gives: a load above it is refused at any time.
        self.amounts = {
            name: {
                r: float(task.uses[r])
                for r in self.held[name]
                if r in resources.multiple
            }
            for name, task in self.tasks.items()
        }
        self.peaks = {
            r: resources.peak_capacity(r) for r in resources.multiple
        }
        # The precedences between kept tasks, by task (the kept set never
        # changes, so their scopes hold throughout).
        self.precedences: dict[str, list[Precedence]] = {
            name: [] for name in self.starts
        }
        for prec in problem.precedences:
            if prec.before in self.starts and prec.after in self.starts:
                self.precedences[prec.before].append(prec)
                self.precedences[prec.after].append(prec)
        self.refusals_left = MAX_REFUSED

    def run(self) -> Plan:
        """Sweep until a sweep keeps no move or the checks run out."""
        while self.checks_left > 0 and self._sweep():
            pass
        return self.best_plan

    def _sweep(self) -> bool:
        """Try each kept task, the most delay cost first; True once a
        move is kept (the caller sweeps again from the new plan)."""
        starts, tasks = self.starts, self.tasks
        order = sorted(
            starts,
            key=lambda n: (
                -(starts[n] - self.domains[n].earliest) * tasks[n].delay_cost,
                n,
            ),
        )
        ends = (at + tasks[n].length for n, at in starts.items())
        points = sorted({*starts.values(), *ends})
        for name in order:
            if self._earlier(name, points):
                return True
            if self.checks_left <= 0:
                return False
        return False

    def _earlier(self, name: str, points: list[int]) -> bool:
        """Try ``name`` at the starts before its own; True once a move
        is kept."""
        task = self.tasks[name]
        now = self.starts[name]
        low = self.domains[name].earliest
        if task.delay_cost <= 0 or now <= low:
            return False
        for start in sorted({low, *(p for p in points if low < p < now)}):
            if self.checks_left <= 0:
                return False
            moved = dict(self.starts)
            moved[name] = start
            if self._keep(moved):
                return True
            if self._push(name, start, moved, points):
                return True
        return False

    def _push(
        self, name: str, start: int, moved: dict[str, int], points: list[int]
    ) -> bool:
        """``name`` at ``start`` with the tasks in its way after it."""
        task = self.tasks[name]
        end = start + task.length
        gain = task.delay_cost * (self.starts[name] - start)
        held = self.held[name]
        in_way = sorted(
            (
                other
                for other, at in self.starts.items()
                if other != name
                and at < end
                and at + self.tasks[other].length > start
                and held & self.held[other]
            ),
            key=lambda other: (self.starts[other], other),
        )
        if not 1 <= len(in_way) <= MAX_PUSHED:
            return False
        if any(end > self.domains[other].latest for other in in_way):
            return False
        # Each task in the way starts before ``end``: it moves to ``end``.
        loss = sum(
            self.tasks[other].delay_cost * (end - self.starts[other])
            for other in in_way
        )
        if loss >= gain:
            return False
        pushed = dict(moved)
        for other in in_way:
            pushed[other] = end
        if self._keep(pushed):
            return True
        if len(in_way) > 1:
            return False
        other = in_way[0]
        latest = self.domains[other].latest
        for point in [p for p in points if end < p <= latest][:LATER_POINTS]:
            if self.checks_left <= 0:
                return False
            if self.tasks[other].delay_cost * (point - self.starts[other]) >= (
                gain
            ):
                return False
            pushed = dict(moved)
            pushed[other] = point
            if self._keep(pushed):
                return True
        return False

    def _keep(self, starts: dict[str, int]) -> bool:
        """Check the plan of ``starts``; keep it if valid and better."""
        if self.checks_left <= 0:
            return False
        if self.refusals_left > 0:
            moved = [n for n, at in starts.items() if at != self.starts[n]]
            if self._refused(starts, moved):
                self.refusals_left -= 1
                if self.refusals_left % ASK_EVERY == 0 and self._stopped():
                    self.checks_left = 0
                return False
        if self._stopped():
            self.checks_left = 0
            return False
        self.checks_left -= 1
        # The same plan building and check as the start heuristic's.
        candidate = checked_starts(self.problem, starts)
        if candidate is None or candidate.objective is None:
            return False
        if candidate.objective.total >= self.best:
            return False
        self.starts = starts
        self.best = candidate.objective.total
        self.best_plan = self.plan.replace(
            activities=candidate.activities, objective=candidate.objective
        )
        return True

    def _stopped(self) -> bool:
        return self.stop is not None and self.stop()

    def _refused(self, starts: dict[str, int], moved: list[str]) -> bool:
        """True if a rule the moved tasks take part in is broken at
        ``starts``: a precedence, two users of a binary resource at once,
        or a multiple resource above its largest capacity while a moved
        task runs. Only plans the checker refuses too are refused here
        (its rules read the same way: :func:`~.check.check_plan`)."""
        tasks = self.tasks
        for name in moved:
            for prec in self.precedences[name]:
                target = (
                    starts[prec.before]
                    + tasks[prec.before].length
                    + prec.offset
                )
                after = starts[prec.after]
                if after < target or (
                    prec.kind == "tight" and after != target
                ):
                    return True
        for name in moved:
            begin = starts[name]
            end = begin + tasks[name].length
            binary, amounts = self.binary[name], self.amounts[name]
            if not binary and not amounts:
                continue
            beside = [
                other
                for other, at in starts.items()
                if other != name
                and at < end
                and at + tasks[other].length > begin
            ]
            if binary and any(binary & self.binary[o] for o in beside):
                return True
            for resource, amount in amounts.items():
                users = [
                    (starts[o], starts[o] + tasks[o].length, a)
                    for o in beside
                    if (a := self.amounts[o].get(resource))
                ]
                # The load is highest at some user's start inside the
                # moved task's run (or at its own start).
                for point in {begin, *(b for b, _, _ in users if b > begin)}:
                    load = amount + sum(
                        a for b, e, a in users if b <= point < e
                    )
                    if load > self.peaks[resource] + TOLERANCE:
                        return True
        return False
