"""Decision variables: one step variable per task and allowed start time.

For task ``i`` with start domain ``[e, l]``, ``z[i, t] = 1`` iff the task is
scheduled and has started by time ``t`` (``t in [e, l]``). The steps are
monotone, ``z[i, l]`` is "scheduled", and expressions outside the domain
are constants: 0 before ``e`` and ``z[i, l]`` from ``l`` on. The start
indicator is ``z[i, t] - z[i, t-1]`` and the task runs at ``t`` iff
``z[i, t] - z[i, t - length] = 1``, so each resource row has two non-zeros
per task instead of ``length`` (this is the step, or "aggregated", form of
the classic time-indexed model, with the same LP bound).

Feasible intervals (both readings), horizon and pins are enforced here, by
the domain: :func:`fsw_scheduler.analysis.domains.start_domains`.

A task may also be given *candidate* starts, a sorted subset of its domain
that holds both its ends: it then has one step per candidate,
``z[i, c_k] = 1`` iff it has started by ``c_k``, and ``z[i, t]`` is the
step of the last candidate at or before ``t``. The rows are written as
before through :meth:`Variables.step`, so they hold for those starts
only: a smaller model of the same problem whose every solution is a plan
(the neighbourhood search's sub-models,
:mod:`fsw_scheduler.solving.improve`).
"""

from __future__ import annotations

import bisect
import itertools
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Collection, Mapping, Sequence

    from ...analysis.domains import Domain
    from ...model.problem import Problem, Task
    from .program import Program, Terms


def shared_steps(
    problem: Problem,
    domains: Mapping[str, Domain],
    sparse: Collection[str] = (),
) -> dict[str, str]:
    """Tasks whose steps are another task's, shifted: task id to that task.

    A tight precedence of scope ``both`` makes ``s_j = s_i + g`` and
    ``y_j = y_i``, so ``Z(j, t) = Z(i, t - g)``: where the domains agree
    (``[e_j, l_j] = [e_i + g, l_i + g]``, as propagation leaves them)
    ``j`` reads ``i``'s columns instead of having its own, and the
    precedence's rows become empty. Chains share one task's columns
    (offsets add up); a pair already linked is not linked again, so a
    cycle of such precedences keeps its rows. Tasks in ``sparse`` (with
    candidate starts) keep their own columns.
    """
    #: Task id to (task it follows, shift of its start from that task's).
    parent: dict[str, tuple[str, int]] = {}

    def root(name: str) -> tuple[str, int]:
        shift = 0
        while name in parent:
            name, step = parent[name]
            shift += step
        return name, shift

    for prec in problem.precedences:
        if prec.kind != "tight" or prec.scope != "both":
            continue
        if prec.before in sparse or prec.after in sparse:
            continue  # candidate starts need not line up
        first, first_shift = root(prec.before)
        second, second_shift = root(prec.after)
        if first == second:
            continue
        gap = problem.task(prec.before).length + prec.offset
        shift = first_shift + gap - second_shift  # s_second - s_first
        dom_a, dom_b = domains[first], domains[second]
        if dom_a.empty or dom_b.empty:
            continue
        if (dom_b.earliest, dom_b.latest) == (
            dom_a.earliest + shift,
            dom_a.latest + shift,
        ):
            parent[second] = (first, shift)
    return {name: root(name)[0] for name in parent}


class Variables:
    """Step variables of every task with a non-empty start domain.

    Parameters
    ----------
    program
        The program that owns the columns.
    problem
        The problem being modelled.
    domains
        Start domains from
        :func:`~fsw_scheduler.analysis.domains.start_domains`.
    candidates
        Task id to its candidate starts (see the module docstring):
        sorted, inside its domain, its first and last the domain's ends.
        Tasks not given have every start of their domain.
    """

    def __init__(
        self,
        program: Program,
        problem: Problem,
        domains: dict[str, Domain],
        candidates: Mapping[str, Sequence[int]] | None = None,
    ) -> None:
        self.problem = problem
        self.domains = domains
        self.tasks: list[Task] = list(problem.tasks)
        self.steps: dict[str, list[int]] = {}
        #: Candidate starts of the tasks that have them (module docstring).
        self.candidates: dict[str, list[int]] = {}
        for name, starts in (candidates or {}).items():
            domain = domains[name]
            if domain.empty:
                continue
            ordered = sorted(set(starts))
            if ordered[0] != domain.earliest or ordered[-1] != domain.latest:
                raise ValueError(
                    f"candidate starts of {name} must begin and end at its "
                    f"domain's ends [{domain.earliest}, {domain.latest}]"
                )
            self.candidates[name] = ordered
        # Between two candidates a unit's rows repeat the unit before's.
        program.skip_repeats = bool(self.candidates)
        shared = shared_steps(problem, domains, self.candidates)
        for task in self.tasks:
            domain = domains[task.id]
            if domain.empty or task.id in shared:
                continue
            count = domain.latest - domain.earliest + 1
            if task.id in self.candidates:
                count = len(self.candidates[task.id])
            self.steps[task.id] = list(program.add_binaries(count))
        for task in self.tasks:
            if task.id in shared and shared[task.id] in self.steps:
                self.steps[task.id] = self.steps[shared[task.id]]
        for task in self.tasks:
            if problem.required(task) and task.id in self.steps:
                program.lower[self.scheduled(task.id)] = 1
        self._spans = {
            task_id: (
                domains[task_id].earliest,
                steps[0],
                domains[task_id].latest,
            )
            for task_id, steps in self.steps.items()
        }

    @property
    def num_placeable(self) -> int:
        """Number of tasks with at least one allowed start time."""
        return len(self.steps)

    def placeable(self, task_id: str) -> bool:
        """True if the task has at least one allowed start time."""
        return task_id in self.steps

    def scheduled(self, task_id: str) -> int:
        """The column that is 1 iff the task is scheduled."""
        return self.steps[task_id][-1]

    def step(self, task_id: str, time: int) -> int | None:
        """``z[task, time]`` as a column, or None where it is 0."""
        span = self._spans.get(task_id)
        if span is None or time < span[0]:
            return None
        first, column, last = span
        # A task's steps are consecutive columns.
        if time >= last:
            return column + len(self.steps[task_id]) - 1
        starts = self.candidates.get(task_id)
        if starts is not None:
            return column + bisect.bisect_right(starts, time) - 1
        return column + (time - first)

    def widths(self, task_id: str) -> list[int]:
        """Time units from each step of ``task_id`` to the next, but the
        last (all 1 without candidate starts): the delay a step saves."""
        starts = self.candidates.get(task_id)
        if starts is None:
            return [1] * (len(self.steps[task_id]) - 1)
        return [b - a for a, b in itertools.pairwise(starts)]

    def add_step(
        self, terms: Terms, task_id: str, time: int, coef: float
    ) -> None:
        """Add ``coef * z[task, time]`` to ``terms`` (skipping zeros)."""
        var = self.step(task_id, time)
        if var is not None:
            terms[var] = terms.get(var, 0.0) + coef

    def add_steps(
        self, terms: Terms, task_id: str, low: int, high: int, coef: float
    ) -> None:
        """Add ``coef * z[task, u]`` to ``terms`` for every u in ``[low,
        high)``: :meth:`add_step` unit by unit, the units past the last
        step (all on the "scheduled" column) added at once: the same sums
        when ``coef`` is a whole number, which callers see to (the level
        rows' units, most of a 15-task model's build)."""
        span = self._spans.get(task_id)
        if span is None:
            return
        first, column, last = span
        low = max(low, first)
        if task_id in self.candidates:
            for time in range(low, high):
                self.add_step(terms, task_id, time, coef)
            return
        for time in range(low, min(high, last)):
            var = column + (time - first)
            terms[var] = terms.get(var, 0.0) + coef
        over = high - max(low, last)
        if over > 0:
            top = column + len(self.steps[task_id]) - 1
            terms[top] = terms.get(top, 0.0) + coef * over

    def starts_at(self, task_id: str, time: int) -> Terms:
        """ "Scheduled and starts at ``time``" as terms of the steps:
        ``z[i, time] - z[i, time - 1]`` (empty where it cannot start)."""
        terms: Terms = {}
        self.add_step(terms, task_id, time, 1.0)
        self.add_step(terms, task_id, time - 1, -1.0)
        return {col: coef for col, coef in terms.items() if coef}

    def running_units(self, task: Task, origin: int, count: int) -> range:
        """The units of ``[origin, origin + count)`` at which some allowed
        start makes ``task`` run (empty if it has none)."""
        span = self._spans.get(task.id)
        if span is None:
            return range(0)
        first, _, last = span
        return range(
            max(first, origin), min(last + task.length, origin + count)
        )

    def add_running(
        self, rows: list[Terms], task: Task, amount: float, origin: int
    ) -> range:
        """Add ``amount * R(task, t)`` to ``rows[t - origin]`` for every t.

        ``R(i, t) = Z(i, t) - Z(i, t - length)`` is "runs at t"; only the
        units at which some allowed start makes the task run get terms.
        Returns those units (within the rows).
        """
        first, column, last = self._spans[task.id]
        times = range(
            max(first, origin), min(last + task.length, origin + len(rows))
        )
        if task.id in self.candidates:
            step = self.step
            for time in times:
                terms = rows[time - origin]
                on = step(task.id, time)
                off = step(task.id, time - task.length)
                if on is not None:
                    terms[on] = terms.get(on, 0.0) + amount
                if off is not None:
                    terms[off] = terms.get(off, 0.0) - amount
            return times
        for time in times:
            terms = rows[time - origin]
            # The steps are the consecutive columns of [first, last],
            # clamped at the ends.
            on = column + min(time, last) - first
            terms[on] = terms.get(on, 0.0) + amount
            if time - task.length >= first:
                off = column + min(time - task.length, last) - first
                terms[off] = terms.get(off, 0.0) - amount
        return times

    def start_of(self, task_id: str, values: Sequence[float]) -> int | None:
        """The start time in solution ``values``, None if unscheduled."""
        steps = self.steps.get(task_id)
        if steps is None or values[steps[-1]] < 0.5:
            return None
        first = self.domains[task_id].earliest
        starts = self.candidates.get(task_id)
        for offset, col in enumerate(steps):
            if values[col] >= 0.5:
                return first + offset if starts is None else starts[offset]
        return None  # unreachable: the last step is 1

    def initial(self, starts: dict[str, int], columns: int) -> list[float]:
        """Column values of a warm start from ``starts``.

        Tasks absent from ``starts`` start as unscheduled (mandatory ones at
        their earliest start); starts outside a task's domain are ignored.
        Columns other than steps are left at 0 for the solver to fill.
        """
        values = [0.0] * columns
        for task in self.tasks:
            steps = self.steps.get(task.id)
            if steps is None:
                continue
            index = self._index(task.id, starts.get(task.id))
            if index is None:
                if not self.problem.required(task):
                    continue
                # A mandatory task new to this problem: suggest its earliest
                # start rather than an unscheduled value below its bound.
                index = 0
            for col in steps[index:]:
                values[col] = 1.0
        return values

    def _index(self, task_id: str, start: int | None) -> int | None:
        """The step at which ``start`` is the task's start, None when it is
        not one of its allowed starts."""
        if start is None:
            return None
        first = self.domains[task_id].earliest
        starts = self.candidates.get(task_id)
        if starts is None:
            count = len(self.steps[task_id])
            return start - first if first <= start < first + count else None
        index = bisect.bisect_left(starts, start)
        found = index < len(starts) and starts[index] == start
        return index if found else None


def with_starts(
    candidates: dict[str, list[int]],
    warm: Mapping[str, int | None],
    domains: Mapping[str, Domain],
) -> dict[str, list[int]]:
    """``candidates`` with each task's start in ``warm`` (inside its
    domain) among its own.

    A warm start the model cannot hold is no start: its step columns
    would put the task at the candidate before, which may break a row,
    and CBC then searches without it. The neighbourhood search gives the
    candidates of its incumbent, and a disjunctive run that hands over
    to the time-indexed model (:func:`~.model._switching`) starts it
    from its own better plan (``tools/fuzz --large`` seed 1218, 47 tasks
    over H = 300 on a power of 3: two rounds started without their
    plan).
    """
    merged = dict(candidates)
    for name, starts in candidates.items():
        at = warm.get(name)
        domain = domains[name]
        if (
            at is not None
            and domain.earliest <= at <= domain.latest
            and at not in starts
        ):
            merged[name] = sorted({*starts, at})
    return merged
