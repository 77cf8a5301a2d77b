"""The list scheduler's resource board: uses, levels, first fits (pure).

What a plan being built uses of each binary and multiple resource, and
its consumable levels, unit by unit.

:mod:`.greedy` books each task as it places it; :mod:`.insert` takes
tasks off and books them elsewhere. :meth:`Board.first_fit` finds a
task's earliest fitting start without trying every start one by one.
"""

from __future__ import annotations

import bisect
import itertools
import math
import operator
import threading
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    from ..model.problem import Problem, Resources, Task


class Board:
    """Resource usage and consumable levels of the plan being built."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        span = problem.horizon
        res = problem.resources
        self.used = {n: [0.0] * span for n in (*res.binary, *res.multiple)}
        self.ceiling = res.ceilings
        self.initial = res.initial_levels
        # Stores with a ceiling: running sums of their net use, worked out
        # when a test needs them (a booking drops them).
        self._sums: dict[str, _Sums] = {}
        empty = _empty_board(res, problem.start, span)
        if empty is not None:
            # Profiles are only read; levels are copied, as each board
            # books its own tasks.
            self.capacity, self.external = empty.capacity, empty.external
            self.level = {n: list(v) for n, v in empty.level.items()}
            self.lowest = {n: list(v) for n, v in empty.lowest.items()}
            self.net = {n: list(v) for n, v in empty.net.items()}
            return
        # The capacity of each unit: windows and steps included.
        self.capacity = {
            name: res.capacity_profile(name, problem.start, span)
            for name in (*res.binary, *res.multiple)
        }
        self.external = ext = {
            n: res.external_profile(n, problem.start, span)
            for n in res.consumable
        }
        # level[t]: level at the end of unit start + t, external rate in
        self.level = {
            name: list(itertools.accumulate(ext[name], initial=initial))[1:]
            for name, initial in res.initial_levels.items()
        }
        # The running minimum from the end: an external rate may dip and
        # come back (an eclipse's drain, then the sun), and a consumer
        # placed before the dip must leave enough for it.
        self.lowest = {name: _suffix_min(v) for name, v in self.level.items()}
        self._capped_init(problem)
        _keep_empty(res, problem.start, span, self)

    def demand(
        self, items: list[tuple[Task, int]]
    ) -> dict[str, tuple[int, list[float]]]:
        """What tasks ``(task, start)`` need together, per resource: the
        first unit they touch and the amounts from there (consumables:
        consumption only). A list, not a table per unit: the amounts add
        up in the order of ``items``."""
        base = self.problem.start
        demand: dict[str, tuple[int, list[float]]] = {}
        for task, start in items:
            first = start - base
            for name, amount in task.uses.items():
                if amount == 0 or (name in self.level and amount < 0):
                    continue
                if name not in self.used and name not in self.level:
                    continue
                low, units = demand.get(name, (first, []))
                if first < low:
                    units[:0] = [0.0] * (low - first)
                    low = first
                end = first - low + task.length
                if end > len(units):
                    units.extend([0.0] * (end - len(units)))
                for k in range(first - low, end):
                    units[k] += amount
                demand[name] = (low, units)
        return demand

    def fits_demand(
        self, demand: dict[str, tuple[int, list[float]]], shift: int
    ) -> bool:
        """True if a :meth:`demand` moved ``shift`` units later can be
        added: a group's shape is the same at every anchor, so it is built
        once and moved.

        Nothing is changed; only the units the demand touches are read,
        plus one look-up of the lowest later level per consumable (the
        drop is constant after the last of its units).
        """
        return self._clash(demand, shift) is None and self._levels_hold(
            demand, shift
        )

    def first_fit_demand(
        self, demand: dict[str, tuple[int, list[float]]], low: int, high: int
    ) -> int | None:
        """The least shift in ``[low, high]`` at which :meth:`fits_demand`
        holds, or None: :meth:`first_fit` for a group's shape.

        The same shift as trying each in turn. Where a binary or multiple
        resource is overrun at a unit, the shifts that bring a unit of the
        shape with no more room there are passed over one look-up each
        (they overrun it too) instead of a whole test each. Groups of
        tasks tied by tight precedences over H = 10,000 took seconds
        shift by shift, past a 1 s limit.
        """
        # What each consumable of the shape takes in all, summed once in
        # unit order (the same floats as a sum per shift): a shape of a
        # 1,000-unit task summed again at every shift tried was most of
        # an insertion's time over H = 2,880.
        drops = {
            name: _sum_in_order(units)
            for name, (_, units) in demand.items()
            if name in self.lowest and name not in self.used
        }
        shift = low
        while shift <= high:
            enough = self._enough_demand(demand, shift, drops)
            if enough > shift:
                shift = enough
                continue
            clash = self._clash(demand, shift)
            if clash is None:
                if self._levels_hold(demand, shift):
                    return shift
                shift += 1
                continue
            name, t = clash
            first, units = demand[name]
            used, cap = self.used[name], self.capacity[name]
            shift += 1
            while shift <= high:
                k = t - first - shift
                if k < 0 or k >= len(units):
                    break
                a = units[k]
                if not (a and used[t] + a > cap[t] + 1e-9):
                    break
                shift += 1
        return None

    def _enough_demand(
        self,
        demand: dict[str, tuple[int, list[float]]],
        shift: int,
        drops: dict[str, float],
    ) -> int:
        """The first shift from ``shift`` on at which every consumable of
        ``demand`` holds, from the shape's end on, what it takes in all
        (``drops``, the sums of :meth:`_levels_hold`): the lowest level
        from a unit on only rises with the unit."""
        for name, drop in drops.items():
            lowest = self.lowest[name]
            first, units = demand[name]
            last = first + shift + len(units)
            if name in self.ceiling:
                after = self._capped_from(name, last, drop, len(units))
            else:
                after = _holding_from(lowest, last, drop)
            shift = max(shift, after - len(units) - first)
        return shift

    def _clash(
        self, demand: dict[str, tuple[int, list[float]]], shift: int
    ) -> tuple[str, int] | None:
        """The first unit (board index) at which ``demand`` moved
        ``shift`` overruns a binary or multiple resource, with its name;
        None if none (the first test of :meth:`fits_demand`)."""
        for name, (first, units) in demand.items():
            used = self.used.get(name)
            if used is None:
                continue
            cap = self.capacity[name]
            low = first + shift
            for k, a in enumerate(units):
                if a and used[low + k] + a > cap[low + k] + 1e-9:
                    return name, low + k
        return None

    def _levels_hold(
        self, demand: dict[str, tuple[int, list[float]]], shift: int
    ) -> bool:
        """True if every consumable of ``demand`` moved ``shift`` stays
        at or above 0 (the second test of :meth:`fits_demand`)."""
        for name, (first, units) in demand.items():
            if name in self.used:
                continue
            low = first + shift
            if name in self.ceiling:
                if not self._capped_holds(name, low, units):
                    return False
                continue
            level = self.level[name]
            drop = 0.0
            for k, a in enumerate(units):
                drop += a
                if level[low + k] - drop < -1e-9:
                    return False
            last = low + len(units) - 1
            if last + 1 < len(level) and (
                self.lowest[name][last + 1] - drop < -1e-9
            ):
                return False
        return True

    def fits_one(self, task: Task, start: int) -> bool:
        """:meth:`fits_demand` for one task at ``start``, without building
        its demand (the common case and the heuristic's hot loop, 1.5x
        faster: the same tests, in the same floating-point order)."""
        first = start - self.problem.start
        end = first + task.length
        for name, amount in task.uses.items():
            if amount == 0:
                continue
            used = self.used.get(name)
            if used is not None:
                cap = self.capacity[name]
                for t in range(first, end):
                    if used[t] + amount > cap[t] + 1e-9:
                        return False
                continue
            level = self.level.get(name)
            if level is None or amount < 0:
                continue
            if name in self.ceiling:
                if not self._capped_holds(name, first, [amount] * task.length):
                    return False
                continue
            drop = 0.0
            for t in range(first, end):
                drop += amount
                if level[t] - drop < -1e-9:
                    return False
            if end < len(level) and self.lowest[name][end] - drop < -1e-9:
                return False
        return True

    def _capped_holds(self, name: str, low: int, units: list[float]) -> bool:
        """True if ``units`` more drawn from board unit ``low`` on keep the
        consumable ``name``, which has a ceiling, at or above 0.

        Taking a drop to last, as the tests of a store without a ceiling
        do, is short here: a store kept full by an external charge loses
        what it cannot take, and a consumer gives that back as it draws
        (a 38-unit task drawing 1 a unit from a store of at most 10
        charged 1 a unit was placed nowhere, though plans hold it). The
        level ``x_t = min(top, x_(t-1) - n_t)`` (``n``: net use, the
        external rate negative; ``x_(-1)``: the initial level) is
        ``min(initial - P_t, min over 0 <= j < t of top - (P_t - P_j))``
        with ``P`` the running sum of ``n``. It stays at or above 0 iff
        ``P_t <= initial`` at every ``t`` and ``P_t - P_j <= top`` for
        every ``j < t``: no stretch draws more than a full store holds.
        Only the terms the new use raises are tested, against the board's
        running minimum and later maximum of ``P``
        (:meth:`_sums_of`): what the drawing adds unit by unit, then its
        whole after it.
        """
        sums = self._sums_of(name)
        top = self.ceiling[name]
        initial = self.initial[name]
        running = sums.running
        low_sum = sums.least[low - 1] if low > 0 else math.inf
        end = min(len(running), low + len(units))
        if end < len(running):
            # What lasts after the drawing, first (one look-up each): the
            # usual reason a start is refused.
            later = sums.most[end] + _sum_in_order(units)
            if later > initial + 1e-9 or later - low_sum > top + 1e-9:
                return False
        added = 0.0
        for t in range(low, end):
            added += units[t - low]
            reached = running[t] + added
            if reached > initial + 1e-9 or reached - low_sum > top + 1e-9:
                return False
            if reached < low_sum:
                low_sum = reached
        if end < len(running):
            later = sums.most[end] + added
            if later - low_sum > top + 1e-9:
                return False
        return True

    def _sums_of(self, name: str) -> _Sums:
        """The running sums of store ``name`` (:class:`_Sums`)."""
        sums = self._sums.get(name)
        if sums is None:
            sums = self._sums[name] = _sums(self.net[name])
        return sums

    def _capped_from(
        self, name: str, end: int, drop: float, length: int
    ) -> int:
        """The first board unit from ``end`` on at which a drawing of
        ``drop`` in all over ``length`` units may end (exclusive) on the
        store ``name``, which has a ceiling; no later end is passed over
        that :meth:`_capped_holds` would accept.

        Two of its tests read sums the drawing does not touch: what is
        left after it against the initial level (the later maximum of
        ``P`` only falls with the unit), and the stretch from the least
        sum before it to the greatest after it against the ceiling; a
        drawing refused on that stretch is refused for every end up to
        that greatest unit too (the stretch still holds it), so those
        ends are passed over at once.
        """
        sums = self._sums_of(name)
        most, least = sums.most, sums.least
        initial, top = self.initial[name], self.ceiling[name]
        while end < len(most):
            later = most[end] + drop
            if later > initial + 1e-9:
                end += 1
                continue
            low = end - length
            if low > 0 and later - least[low - 1] > top + 1e-9:
                # The last unit at which the greatest sum from ``end`` on
                # is reached (``most`` does not rise).
                peak = bisect.bisect_right(
                    most, -most[end], lo=end, key=operator.neg
                )
                end = max(end + 1, peak)
                continue
            return end
        return end

    def overrun(self, task: Task, start: int) -> tuple[int, str] | None:
        """The last unit (absolute) at which ``task`` at ``start`` overruns
        a binary or multiple resource, with its name; None if none (the
        first test of :meth:`fits_one`)."""
        base = start - self.problem.start
        for name, amount in task.uses.items():
            used = self.used.get(name)
            if used is None or amount == 0:
                continue
            cap = self.capacity[name]
            for t in range(base + task.length - 1, base - 1, -1):
                if used[t] + amount > cap[t] + 1e-9:
                    return t + self.problem.start, name
        return None

    def first_fit(self, task: Task, low: int, high: int) -> int | None:
        """The earliest start in ``[low, high]`` at which :meth:`fits_one`
        holds, or None.

        The same start as trying each in turn, without trying them all:
        past the last unit a resource is overrun at once (every start up
        to it overlaps it), and past the starts at which a consumable's
        lowest level from the task's end on is below what it takes in all
        (that level only rises with the unit it is read from). On 60
        tasks over H = 2880 the list schedule spent most of its seconds
        trying starts one by one.
        """
        start = low
        while start <= high:
            clash = self.overrun(task, start)
            if clash is not None:
                start = clash[0] + 1
                continue
            enough = self._enough_from(task, start)
            if enough > start:
                start = enough
                continue
            if self.fits_one(task, start):
                return start
            start += 1
        return None

    def _enough_from(self, task: Task, start: int) -> int:
        """The first start from ``start`` on at which every consumable
        ``task`` draws on holds, from its end on, what it takes in all
        (the last test of :meth:`fits_one`, with the same sum)."""
        base = self.problem.start
        for name, amount in task.uses.items():
            lowest = self.lowest.get(name)
            if lowest is None or amount <= 0:
                continue
            drop = 0.0
            for _ in range(task.length):
                drop += amount
            if name in self.ceiling:
                # A store with a ceiling refills: only the total drawn
                # against the initial level is sure to last.
                end = self._capped_from(
                    name, start - base + task.length, drop, task.length
                )
            else:
                end = _holding_from(lowest, start - base + task.length, drop)
            start = max(start, end - task.length + base)
        return start

    def add(self, task: Task, start: int, sign: float = 1.0) -> None:
        """Book ``task`` at ``start`` (``sign=-1`` takes it back)."""
        base = start - self.problem.start
        for name, use in task.uses.items():
            amount = sign * use
            if name in self.used:
                # Slices, not a loop of indexed additions: the same sums,
                # several times faster on tasks of hundreds of units.
                used = self.used[name]
                end = base + task.length
                used[base:end] = [value + amount for value in used[base:end]]
            elif name in self.ceiling:
                self._add_capped(name, base, task.length, amount)
            elif name in self.level:
                level = self.level[name]
                # amount * min(t - base + 1, length), in two runs.
                length = task.length
                end = base + min(length, len(level) - base)
                level[base:end] = [
                    value - amount * k
                    for k, value in enumerate(level[base:end], 1)
                ]
                whole = amount * length
                tail = base + length
                if tail < len(level):
                    level[tail:] = [value - whole for value in level[tail:]]
                self._lowered(name, base, tail, whole)

    def _capped_init(self, problem: Problem) -> None:
        """Consumables with a capacity: net use per unit, walked again.

        Their level is ``min(max, level - net use)`` unit by unit, which
        adding a task cannot shift by a constant, so :meth:`add` walks the
        whole profile again. :meth:`fits` keeps its test: a consumer lowers
        each later level by at most what it has taken by then (a full store
        can only absorb a drop), so a placement it accepts is valid.
        """
        # Net use per unit: the external rate counts as negative use.
        self.net = {
            name: [-rate for rate in self.external[name]]
            for name in self.ceiling
        }
        for name in self.ceiling:
            self._add_capped(name, 0, 0, 0.0)

    def _add_capped(
        self, name: str, base: int, length: int, amount: float
    ) -> None:
        """Book ``amount`` per unit over ``[base, base + length)``."""
        net, level = self.net[name], self.level[name]
        for t in range(max(base, 0), min(base + length, len(net))):
            net[t] += amount
        # Levels before ``base`` do not change: the walk starts there, from
        # the level before it (the same sums in the same order as a walk
        # from the start: the same floats).
        self._sums.pop(name, None)
        first = min(max(base, 0), len(net))
        value = level[first - 1] if first > 0 else self.initial[name]
        top = self.ceiling[name]
        if not any(itertools.islice(net, first, None)):
            # Nothing used from here on: min(top, value - 0) at every unit.
            level[first:] = [min(top, value)] * (len(net) - first)
            if first == 0:  # one level throughout: its own running minimum
                self.lowest[name] = list(level)
            else:
                self._refresh(name)
            return
        for t in range(first, len(net)):
            value = min(top, value - net[t])
            level[t] = value
        self._refresh(name)

    def _lowered(self, name: str, base: int, tail: int, whole: float) -> None:
        """:meth:`_refresh` after the levels from ``tail`` on all moved by
        ``-whole`` (and those of ``[base, tail)`` by other amounts), the
        same list: from ``tail`` on each running minimum moves by
        ``-whole`` too (subtracting one number keeps the order of floats,
        so the same element stays least, and its new value is the same
        subtraction), and the minimum runs on from there to the start. A
        task booked walked the horizon three times in Python, most of
        the start heuristic's time on 15 tasks with a battery."""
        level, lowest = self.level[name], self.lowest[name]
        if tail >= len(level):
            self._refresh(name)
            return
        rest = [value - whole for value in lowest[tail:]]
        if whole < 0 or base <= 0:
            # Levels rose: a running minimum before ``base`` may rise to
            # any level of its stretch, so it is walked again.
            head = list(
                itertools.accumulate(
                    reversed(level[:tail]), min, initial=rest[0]
                )
            )
            head.reverse()
            head.pop()  # the initial value, rest[0]
            self.lowest[name] = head + rest
            return
        # Levels only fell (a consumer booked): the minimum of the units the
        # task runs in, walked, then before ``base`` the old minimum or the
        # new one at ``base``, whichever is less. The old minima do not
        # fall with the unit, so those above the new one are a stretch
        # ending at ``base``, found by bisection and filled at once: the
        # walk back to the horizon's start (a third of a list schedule's
        # time over H = 2,880 with a battery) is left out. The same floats:
        # min only picks values.
        least = rest[0]
        middle = [0.0] * (tail - base)
        for t in range(tail - 1, base - 1, -1):
            value = level[t]
            if value < least:
                least = value
            middle[t - base] = least
        above = bisect.bisect_right(lowest, least, 0, base)
        lowest[above:] = [least] * (base - above) + middle + rest

    def _refresh(self, name: str) -> None:
        """lowest[t] = min(level[t:]), for the constant-drop test."""
        self.lowest[name] = _suffix_min(self.level[name])


class _Sums(NamedTuple):
    """A store's running sum of net use, its running minimum and its
    maximum from each unit on (:meth:`Board._capped_holds`)."""

    running: list[float]
    least: list[float]
    most: list[float]


def _sums(net: list[float]) -> _Sums:
    running = list(itertools.accumulate(net))
    most = list(itertools.accumulate(reversed(running), max))
    most.reverse()
    return _Sums(running, list(itertools.accumulate(running, min)), most)


def _suffix_min(values: list[float]) -> list[float]:
    """``[min(values[t:]) for t]`` (exact: min only picks values)."""
    lowest = list(itertools.accumulate(reversed(values), min))
    lowest.reverse()
    return lowest


class _Empty(NamedTuple):
    """A board with nothing booked: what every board of the same
    resources and horizon starts from."""

    capacity: dict[str, list[float]]
    external: dict[str, list[float]]
    level: dict[str, list[float]]
    lowest: dict[str, list[float]]
    net: dict[str, list[float]]


#: Empty boards kept, by resources (the object), start and horizon: the
#: start heuristic builds a board per rule and per independent part, all
#: over the same resources; over a long horizon with an external rate
#: each took a walk of the horizon (150 tasks in 28 parts over 100,000
#: units: 28 walks, most of a 1 s limit). A few only: each holds a few
#: lists of the horizon's length.
_EMPTY_KEPT = 2
_empty: dict[tuple[int, int, int], tuple[Resources, _Empty]] = {}
_empty_lock = threading.Lock()


def _empty_board(res: Resources, start: int, span: int) -> _Empty | None:
    """The kept empty board of ``res`` over ``[start, start + span)``."""
    with _empty_lock:
        found = _empty.get((id(res), start, span))
    # The resources object itself is kept with it: its id is not reused.
    return found[1] if found is not None and found[0] is res else None


def _keep_empty(res: Resources, start: int, span: int, board: Board) -> None:
    """Keep ``board`` (just built, nothing booked) as the empty board."""
    empty = _Empty(
        board.capacity,
        board.external,
        {n: list(v) for n, v in board.level.items()},
        {n: list(v) for n, v in board.lowest.items()},
        {n: list(v) for n, v in board.net.items()},
    )
    with _empty_lock:
        _empty[(id(res), start, span)] = (res, empty)
        while len(_empty) > _EMPTY_KEPT:
            _empty.pop(next(iter(_empty)))


def _sum_in_order(values: list[float]) -> float:
    """``values`` summed first to last from 0.0, one float addition at a
    time: the sum every level test of a shape reads (``sum`` may differ
    in its last bit from Python 3.12 on, which adds more exactly)."""
    total = 0.0
    for value in values:
        total += value
    return total


def _holding_from(lowest: list[float], index: int, drop: float) -> int:
    """The first index from ``index`` on whose lowest later level holds
    ``drop`` (``len(lowest)`` past the end): ``lowest`` only rises with
    the index, so every one before it falls short."""
    while index < len(lowest) and lowest[index] - drop < -1e-9:
        index += 1
    return index
