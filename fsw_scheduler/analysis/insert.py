"""Left-out tasks inserted into a plan by moving what blocks them (pure).

List scheduling places each task at its earliest fitting start when its
turn comes; a task that finds no room then is left out for good, even
where moving one or two tasks already placed would make room for it. On
the large suite's broad problems (45-60 tasks, three binary resources,
shared power and a battery) the start plan left out 6-10 tasks more than
CP-SAT's plans, nearly all of them ones CP-SAT keeps, and neither the
neighbourhood search (windows of 6-18 tasks, about a second of CBC each)
nor the relaxation recovered them within 20 s.

:func:`inserted` works on the plan itself, as an insertion heuristic
with ejection (in the manner of iterative repair): for each left-out
task, the most valuable first, at a few starts in its window (its
domain, narrowed by its placed precedence partners), it takes out the
placed tasks that block it there (the users of the binary or multiple
resource it would overrun, at most :data:`MAX_EJECTED`), places it, and
puts each task taken out back at its earliest fitting start within its
own window. A task short of a consumable there takes it from the
placed consumers worth least per unit they draw (at most
:data:`MAX_DRAINED`, worth less together than what is inserted), which
are put back only where they still fit. A task that finds no room again
is left out if that keeps the precedences; a required one undoes the
move. A left-out task tied by a tight precedence to a placed one has a
single start; when nothing fits there, the placed partners are lifted
and placed again with it, first. A move is kept when the objective
falls (leaving out less counts first); the consumable levels are
checked after it, and the plan found is returned only if the checker
accepts it. The work is bounded in moves tried (:data:`MAX_TRIES`), not
in seconds, so the answer is the same on every machine.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..model import groups
from ..model.plan import Activity, Plan, SolveStatus, objective_weight
from .board import Board
from .check import check_plan
from .proofs import precedence_needs, reach

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..model.problem import Precedence, Problem, Task
    from .domains import Domain

#: Placed tasks taken out at most to make room for one left-out task. A
#: long task over every binary resource at the horizon's start (a
#: battery's largest supply, seed 68's b60-h1440 of the large suite)
#: has five to ten in its way, which CP-SAT's plan moves hundreds of
#: units later; at 3 it was never tried (69 left out; 59 at 6, the
#: same at 12 and 20 on the 83 large-suite start plans of seeds 60-68).
MAX_EJECTED = 6
#: Consumers taken out at most to leave a left-out task enough of a
#: consumable.
MAX_DRAINED = 3
#: Starts tried per left-out task and sweep, the fewest blockers first.
MAX_STARTS = 8
#: Moves tried in all (each costs a few board updates: milliseconds on
#: 60 tasks over H = 2880 with a battery).
MAX_TRIES = 400
#: Left-out tasks inserted together at most (one and the ones its
#: precedences need: seed 63's f45-h2880 of the large suite ties four by
#: ``both`` precedences).
MAX_CHAIN = 6
#: Sweeps over the left-out tasks (a sweep follows only a kept move).
MAX_PASSES = 3

_EPS = 1e-9


def inserted(
    problem: Problem,
    plan: Plan,
    domains: dict[str, Domain],
    *,
    stop: Callable[[], bool] | None = None,
) -> Plan:
    """``plan``, or a better one with left-out tasks inserted.

    Parameters
    ----------
    problem
        A validated problem; groups of alternatives and resources that
        change over time included (the board reads each unit's capacity
        and external rate, and the checker judges the plan).
    plan
        A valid plan of ``problem`` with its objective.
    domains
        The problem's start domains.
    stop
        True when time is up (the caller's deadline; this module reads
        no clock): the moves kept so far are returned.

    Returns
    -------
    Plan
        ``plan`` itself when no move was kept; else a plan of status
        ``feasible`` that the checker accepts, with a lower objective.
    """
    if plan.objective is None or not plan.unscheduled:
        return plan
    state = _Inserting(problem, plan, domains)
    tries = 0
    for _ in range(MAX_PASSES):
        kept = False
        for name in state.left_out():
            if tries >= MAX_TRIES or (stop is not None and stop()):
                return state.plan(plan)
            used, gained = state.insert(name, MAX_TRIES - tries)
            tries += used
            kept |= gained
        if not kept:
            break
    return state.plan(plan)


class _Inserting:
    """The plan being improved: its starts and its resource board."""

    def __init__(
        self, problem: Problem, plan: Plan, domains: dict[str, Domain]
    ) -> None:
        self.problem = problem
        self.domains = domains
        self.tasks = {t.id: t for t in problem.tasks}
        self.starts = plan.starts()
        self.board = Board(problem)
        for name, start in self.starts.items():
            self.board.add(self.tasks[name], start)
        self.weight = objective_weight(
            [t.delay_cost for t in problem.tasks], problem.horizon
        )
        self.needs = precedence_needs(problem)
        self.precedences: dict[str, list[Precedence]] = {
            t.id: [] for t in problem.tasks
        }
        # Each task's partners by tight precedences, either way.
        self.tight: dict[str, list[str]] = {t.id: [] for t in problem.tasks}
        for prec in problem.precedences:
            self.precedences[prec.before].append(prec)
            self.precedences[prec.after].append(prec)
            if prec.kind == "tight":
                self.tight[prec.before].append(prec.after)
                self.tight[prec.after].append(prec.before)
        self.cost = self._total(self.starts)
        # Tasks of the chain being inserted not yet placed: a ``both``
        # precedence waiting for one of them still holds.
        self.pending: set[str] = set()
        # What the chain being inserted is worth (schedule costs).
        self.worth = 0

    def left_out(self) -> list[str]:
        """Left-out tasks that could be placed, the most valuable first."""
        # A group's members come in or go out by whole options: not one
        # by one here (their own costs are not the objective's).
        member = self.problem.groups.member
        names = [
            t.id
            for t in self.problem.tasks
            if t.id not in self.starts
            and not self.domains[t.id].empty
            and t.id not in member
        ]
        return sorted(
            names,
            key=lambda n: (
                -self.tasks[n].schedule_cost,
                -self.tasks[n].delay_cost,
                n,
            ),
        )

    def insert(self, name: str, budget: int) -> tuple[int, bool]:
        """Try ``name``, with the left-out tasks its precedences need
        (:meth:`_needed`), at up to :data:`MAX_STARTS` starts each (at
        most ``budget`` moves); keep the first move that lowers the
        objective. When none does and placed tasks are tied to the chain
        by tight precedences (its window then a single start, where
        something may be in the way), once more with those tasks lifted
        and placed again first (:meth:`_tied`). Returns the moves tried
        and whether one was kept."""
        chain = self._needed(name)
        if chain is None:
            return 0, False
        tried, kept = self._try(chain, [], budget)
        if kept or tried >= budget:
            return tried, kept
        lifted = self._tied(chain)
        if not lifted or len(chain) + len(lifted) > MAX_CHAIN:
            return tried, kept
        ordered = self._ordered([*lifted, *chain])
        if ordered is None:
            return tried, kept
        more, kept = self._try(ordered, lifted, budget - tried)
        return tried + more, kept

    def _try(
        self, chain: list[str], lifted: list[str], budget: int
    ) -> tuple[int, bool]:
        """Place ``chain`` (placed tasks ``lifted`` among them, taken off
        the board first) depth first; keep the first placement that
        lowers the objective, else put everything back."""
        # What the chain is worth: consumers left out to make room for
        # one of its tasks may cost up to that.
        self.worth = sum(
            self.tasks[n].schedule_cost for n in chain if n not in lifted
        )
        tried = [0]
        done: list[tuple[Task, int, float]] = []

        def book(other: Task, at: int, sign: float) -> None:
            self.board.add(other, at, sign)
            done.append((other, at, sign))

        def undo(mark: int) -> None:
            while len(done) > mark:
                other, at, sign = done.pop()
                self.board.add(other, at, -sign)

        def place(k: int, starts: dict[str, int]) -> bool:
            # Depth first: the chain's k-th task at each of its starts.
            if k == len(chain):
                self.pending = set()
                total = self._total(starts)
                if total < self.cost and self._levels_ok():
                    self.starts, self.cost = starts, total
                    return True
                return False
            task = self.tasks[chain[k]]
            self.pending = set(chain[k + 1 :])
            window = self._window(task.id, starts)
            if window is None:
                return False
            for start in self._candidates(task, starts, *window)[
                : MAX_STARTS if k == 0 else MAX_STARTS // 2
            ]:
                if tried[0] >= budget:
                    return False
                tried[0] += 1
                mark = len(done)
                moved = self._move(task, start, dict(starts), book)
                if moved is not None and place(k + 1, moved):
                    return True
                undo(mark)
            return False

        base = dict(self.starts)
        for name in lifted:
            book(self.tasks[name], base.pop(name), -1.0)
        kept = place(0, base)
        if not kept:
            undo(0)
        self.pending = set()
        return tried[0], kept

    def _tied(self, chain: list[str]) -> list[str]:
        """The placed tasks tied to ``chain`` by tight precedences,
        directly or through one another (large suite, seed 213's
        b45-h2880: its start plan 12.94 M, 11.11 M with them lifted)."""
        tied = reach(set(chain), self.tight, within=self.starts.keys())
        return sorted(tied - set(chain))

    def _needed(self, name: str) -> list[str] | None:
        """``name`` and the left-out tasks it cannot be placed without
        (the first task of a precedence it follows, the second of a
        ``both`` one it leads), first tasks first; None when more than
        :data:`MAX_CHAIN` or one that cannot be placed."""
        needed = [name]
        for current in needed:
            for other in self.needs[current]:
                if other not in self.starts and other not in needed:
                    needed.append(other)
        if len(needed) > MAX_CHAIN or any(
            self.domains[n].empty for n in needed
        ):
            return None
        return self._ordered(needed)

    def _ordered(self, needed: list[str]) -> list[str] | None:
        """``needed`` in a precedence order among themselves, earlier
        in ``needed`` first among those ready; None on a cycle (which
        the problem's validation refuses)."""
        rank = {n: k for k, n in enumerate(needed)}
        ordered: list[str] = []
        while len(ordered) < len(needed):
            ready = [
                n
                for n in needed
                if n not in ordered
                and all(
                    p.before not in rank or p.before in ordered
                    for p in self.precedences[n]
                    if p.after == n
                )
            ]
            if not ready:
                return None
            ordered.append(min(ready, key=rank.__getitem__))
        return ordered

    def plan(self, original: Plan) -> Plan:
        """The plan of the current starts, if better and checked, else
        ``original``."""
        if original.objective is None or self.cost >= original.objective.total:
            return original
        found = Plan(
            status=SolveStatus.FEASIBLE,
            objective=None,
            activities=tuple(
                sorted(
                    (
                        Activity(n, s, s + self.tasks[n].length)
                        for n, s in self.starts.items()
                    ),
                    key=lambda a: (a.start, a.task),
                )
            ),
            unscheduled=groups.left_out(self.problem, self.starts),
            chosen=groups.chosen(self.problem, self.starts),
        )
        report = check_plan(self.problem, found)
        if (
            not report.ok
            or report.objective is None
            or report.objective.total >= original.objective.total
        ):
            return original
        return found.replace(objective=report.objective)

    def _total(self, starts: dict[str, int]) -> int:
        """The objective of a plan with ``starts`` (groups left out cost
        their own; resources that change over time are not read here)."""
        missed = groups.unscheduled_cost(self.problem, starts)
        delay = sum(
            self.tasks[n].delay_cost * (s - self.problem.start)
            for n, s in starts.items()
        )
        return self.weight * missed + delay

    def _window(
        self, name: str, starts: dict[str, int]
    ) -> tuple[int, int] | None:
        """Starts of ``name`` its domain and its placed precedence
        partners in ``starts`` allow; None when it cannot be placed (a
        partner it needs is out, or nothing is left)."""
        task = self.tasks[name]
        domain = self.domains[name]
        if domain.empty:
            return None
        low, high = domain.earliest, domain.latest
        for prec in self.precedences[name]:
            if prec.after == name:
                before = starts.get(prec.before)
                if before is None:
                    return None  # both scopes need the first task
                at = before + self.tasks[prec.before].length + prec.offset
                low = max(low, at)
                if prec.kind == "tight":
                    high = min(high, at)
            else:
                after = starts.get(prec.after)
                if after is None:
                    if prec.scope == "both" and prec.after not in self.pending:
                        return None
                    continue
                at = after - task.length - prec.offset
                high = min(high, at)
                if prec.kind == "tight":
                    low = max(low, at)
        return (low, high) if low <= high else None

    def _precedences_hold(self, starts: dict[str, int]) -> bool:
        """True if every task in ``starts`` is within its window."""
        for name, start in starts.items():
            window = self._window(name, starts)
            if window is None or not window[0] <= start <= window[1]:
                return False
        return True

    def _droppable(self, name: str, starts: dict[str, int]) -> bool:
        """True if leaving ``name`` out keeps every precedence scope of
        the tasks in ``starts``."""
        for prec in self.precedences[name]:
            if prec.before == name and prec.after in starts:
                return False
            if (
                prec.after == name
                and prec.scope == "both"
                and prec.before in starts
            ):
                return False
        return (
            not self.problem.required(self.tasks[name])
            and name not in self.problem.groups.member
        )

    def _candidates(
        self, task: Task, starts: dict[str, int], low: int, high: int
    ) -> list[int]:
        """Starts to try: the window's first, and those that end or begin
        ``task`` at the edge of a placed task sharing a resource with it,
        ordered by what the tasks in the way are worth."""
        shared = {
            n for n, a in task.uses.items() if a and n in self.board.used
        }
        users = [
            n
            for n in starts
            if any(self.tasks[n].uses.get(r, 0) > 0 for r in shared)
        ]
        points = {low}
        # Where it fits as the board stands: for a task drawing on a
        # consumable the window's first start may hold too little of it.
        fit = self.board.first_fit(task, low, high)
        if fit is not None:
            points.add(fit)
        for n in users:
            s, length = starts[n], self.tasks[n].length
            points |= {s, s + length, s - task.length}
        binary = [r for r in shared if r in self.problem.resources.binary]

        def in_way(start: int) -> tuple[int, int, int]:
            end = start + task.length
            way = [
                n
                for n in users
                if starts[n] < end
                and starts[n] + self.tasks[n].length > start
                and any(self.tasks[n].uses.get(r, 0) > 0 for r in binary)
            ]
            worth = sum(self.tasks[n].schedule_cost for n in way)
            return len(way), worth, start

        ranked = sorted(
            (in_way(p) for p in points if low <= p <= high),
        )
        return [start for count, _, start in ranked if count <= MAX_EJECTED]

    def _levels_ok(self) -> bool:
        """True if no consumable level on the board is below zero."""
        return all(lowest[0] >= -_EPS for lowest in self.board.lowest.values())

    def _drained(
        self,
        task: Task,
        start: int,
        starts: dict[str, int],
        book: Callable[[Task, int, float], None],
        out: list[str],
    ) -> bool:
        """True once ``task`` fits at ``start`` with consumers of the
        consumables it runs short of taken out (through ``book``, their
        names added to ``out`` to be put back where they still fit).

        A consumable's level is spent over the whole horizon, not where
        the task stands: the tasks worth least per unit they draw go
        first, as a knapsack's greedy does, up to :data:`MAX_DRAINED`;
        none that supplies one of them (seed 63's f45-h2880 of the large
        suite: a battery of 40 units drawn by 12 tasks, where CP-SAT's
        plan keeps dearer consumers than the product's).
        """
        tasks = self.tasks
        drawn = [
            name
            for name, amount in task.uses.items()
            if amount > 0 and name in self.board.level
        ]
        if not drawn:
            return False

        def draw(name: str) -> float:
            uses = [tasks[name].uses.get(r, 0.0) for r in drawn]
            if any(use < 0 for use in uses):
                return 0.0  # a supply: taking it out leaves less
            return sum(uses) * tasks[name].length

        draws = {n: draw(n) for n in starts if n not in self.pending}
        ranked = sorted(
            (
                n
                for n, drew in draws.items()
                if drew > 0 and self._droppable(n, starts)
            ),
            key=lambda n: (tasks[n].schedule_cost / draws[n], n),
        )
        worth = 0
        for taken, name in enumerate(ranked):
            worth += tasks[name].schedule_cost
            # Leaving out as much as the chain is worth cannot pay.
            if taken >= MAX_DRAINED or worth >= self.worth:
                return False
            book(tasks[name], starts.pop(name), -1.0)
            out.append(name)
            if self.board.fits_one(task, start):
                return True
        return False

    def _move(
        self,
        task: Task,
        start: int,
        starts: dict[str, int],
        book: Callable[[Task, int, float], None],
    ) -> dict[str, int] | None:
        """``starts`` with ``task`` inserted at ``start``, what blocks it
        taken out and put back (each board change through ``book``, for
        the caller to undo); None when that fails (a task taken out that
        must stay finds no room, or a precedence breaks)."""
        tasks = self.tasks
        out: list[str] = []
        while (clash := self.board.overrun(task, start)) is not None:
            unit, resource = clash
            users = [
                n
                for n, s in starts.items()
                if tasks[n].uses.get(resource, 0) > 0
                and s <= unit < s + tasks[n].length
            ]
            if not users or len(out) >= MAX_EJECTED:
                return None
            # The heaviest user first, then the least valuable.
            pick = max(
                users,
                key=lambda n: (
                    tasks[n].uses[resource],
                    -tasks[n].schedule_cost,
                    n,
                ),
            )
            book(tasks[pick], starts.pop(pick), -1.0)
            out.append(pick)
        if not self.board.fits_one(task, start) and not self._drained(
            task, start, starts, book, out
        ):
            return None
        book(task, start, 1.0)
        starts[task.id] = start
        out.sort(key=lambda n: (-tasks[n].schedule_cost, n))
        for name in out:
            window = self._window(name, starts)
            at = None
            if window is not None:
                at = self.board.first_fit(tasks[name], *window)
            if at is None:
                if not self._droppable(name, starts):
                    return None
                continue
            book(tasks[name], at, 1.0)
            starts[name] = at
        return starts if self._precedences_hold(starts) else None
