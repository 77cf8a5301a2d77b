"""A fast list-scheduling heuristic: a valid plan in milliseconds (pure).

It serves twice: as the MIP start of every solve (CBC then begins with an
incumbent, which often closes the search at the root), and as the answer
of last resort when the solver finds nothing within its time limit, so the
scheduler always has a valid plan to fly with. Its plans are never trusted
blindly: :func:`greedy_plan` returns a plan only if the independent checker
finds no violation.

Tasks tied by tight precedences have fixed start offsets, so they are
placed together as one *group*. Groups are taken in precedence order, the
first by a priority rule among those ready, each at the earliest start
where every member fits its window, the resources, the consumable levels
and its lax predecessors.

One priority order suits no problem class: by value (mandatory, then
schedule cost, then delay cost) wastes a scarce consumable on big
consumers, fills a busy resource with long tasks first, and lets tasks
with wide windows take the slots narrow ones need. So the pass is run with
each rule of :data:`~.rules.RULES` (:mod:`.rules`) and the best plan is
kept (the first rule wins ties): a better plan for 14 of the paper
campaign's 84 problems, often the optimum, at about 2 ms a pass.
:func:`plan_in_order` runs it in any order.
"""

from __future__ import annotations

from collections import defaultdict
from typing import TYPE_CHECKING, Any

from ..model import groups
from ..model.plan import (
    Activity,
    Objective,
    Plan,
    SolveStatus,
    objective_weight,
)
from .board import Board
from .check import check_plan
from .domains import Domain, start_domains
from .linked import linked
from .proofs import conflict_seeds, forced_tasks
from .rules import (
    RULES,
    Rule,
    by_deadline,
    by_deadline_forced_first,
    by_supply,
)
from .supply import charges_a_store, supply_sets

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence, Set

    from ..model.problem import Problem, Task


def _tight_groups(problem: Problem) -> list[dict[str, int]]:
    """Tight-connected tasks with their start offsets from the group root."""
    length = {t.id: t.length for t in problem.tasks}
    offset: dict[str, tuple[str, int]] = {
        t.id: (t.id, 0) for t in problem.tasks
    }

    def find(name: str) -> tuple[str, int]:
        total = 0
        while offset[name][0] != name:
            parent, shift = offset[name]
            total += shift
            name = parent
        return name, total

    for prec in problem.precedences:
        if prec.kind != "tight":
            continue
        root_b, off_b = find(prec.before)
        root_a, off_a = find(prec.after)
        if root_a != root_b:
            gap = length[prec.before] + prec.offset
            offset[root_a] = (root_b, off_b + gap - off_a)
    groups: dict[str, dict[str, int]] = defaultdict(dict)
    for task in problem.tasks:
        root, shift = find(task.id)
        groups[root][task.id] = shift
    result = []
    for members in groups.values():
        low = min(members.values())
        result.append({k: v - low for k, v in members.items()})
    return result


def greedy_plan(
    problem: Problem,
    *,
    stop: Callable[[], bool] | None = None,
    domains: dict[str, Domain] | None = None,
    apart: bool = True,
) -> Plan | None:
    """The best valid plan list scheduling finds, or None.

    First the *trivial* plan: the tasks every plan must hold
    (:func:`~fsw_scheduler.analysis.proofs.forced_tasks`) alone, by the
    deadline
    rule. Then each rule of :data:`~.rules.RULES` gives one plan (see
    :func:`_rule_plan`); the one with the lowest objective is returned,
    the earliest rule on a tie and the trivial plan last. A plan with
    every task at its earliest start cannot be beaten, so the remaining
    rules are then skipped, and so are they once ``stop()`` is true.

    Parameters
    ----------
    problem
        A validated problem.
    stop
        Asked between and during rules; true when time is up (the caller's
        deadline: this module reads no clock). The trivial plan is always
        completed.
    domains
        The problem's :func:`start_domains`, if already known.
    apart
        When no rule places every task that must be held: plan those
        alone, then the others around them (:func:`_forced_apart`).

    Returns
    -------
    Plan or None
        Status ``feasible``, objective computed; None when no rule places
        every mandatory task in a plan the checker accepts.
    """
    if domains is None:
        domains = start_domains(problem)
    forced = forced_tasks(problem)
    seeds = conflict_seeds(problem, forced)
    # The plan with only the forced tasks: no plan found may be worse.
    trivial = _rule_plan(
        problem,
        by_deadline(problem, domains, forced),
        domains,
        seeds | {t.id for t in problem.tasks if t.id not in forced},
    )
    supplied = supply_sets(problem, domains, forced)
    charges = {
        t.id
        for t in problem.tasks
        if not domains[t.id].empty and charges_a_store(problem, t)
    }
    candidates: list[Plan] = []

    def placed(rule: Rule, first: set[str] | None) -> Plan | None:
        return _rule_plan(
            problem,
            rule(problem, domains, forced),
            domains,
            seeds,
            stop=stop,
            first=first,
        )

    for rule in RULES.values():
        if stop is not None and stop():
            break
        # The supply rule tries ever more generators until one places
        # every mandatory task; the others run once.
        firsts: list[set[str] | None] = [None]
        if rule is by_deadline_forced_first:
            firsts = [forced]
        elif rule is by_supply:
            firsts = list(supplied)
        plan = None
        for first in firsts:
            plan = placed(rule, first)
            if plan is not None:
                break
        if rule is by_supply and charges and charges not in firsts:
            # Once more with every task that charges a store first: the
            # consumers that need them may all be optional, and then the
            # supply sets hold none of them (see by_supply).
            more = placed(rule, charges)
            if more is not None:
                candidates.append(more)
        if plan is None:
            continue
        candidates.append(plan)
        if not plan.unscheduled and all(
            a.start == domains[a.task].earliest for a in plan.activities
        ):
            break
    if trivial is not None:
        candidates.append(trivial)

    def cost(plan: Plan) -> int:
        return plan.objective.total if plan.objective else 0

    if candidates:
        candidates += _bundles_first(
            problem, domains, forced, seeds, min(candidates, key=cost), stop
        )
    # The checker runs on the best candidate only, then the next ones if
    # it refuses (it never has: it is the heuristic's safety net).
    candidates.sort(key=cost)
    found = next((p for p in candidates if check_plan(problem, p).ok), None)
    if found is not None or not apart or (stop is not None and stop()):
        return found
    return _forced_apart(problem, forced, stop)


def unplaced(
    problem: Problem, *, stop: Callable[[], bool] | None = None
) -> list[frozenset[str]]:
    """What one pass of each rule could not place of the tasks every plan
    must hold: the distinct sets, the smallest first (then by name).

    Empty when a rule places them all (or ``stop()`` turns true before
    any pass ends). For a caller that may let those tasks go: the tasks a
    relaxation keeps, each made mandatory, that no rule places whole
    (:func:`~fsw_scheduler.analysis.bounds.kept_set_starts`).
    """
    domains = start_domains(problem)
    forced = forced_tasks(problem)
    seeds = conflict_seeds(problem, forced)
    found: set[frozenset[str]] = set()
    for rule in RULES.values():
        starts = _list_schedule(
            problem, seeds, rule(problem, domains, forced), domains, stop=stop
        )
        if starts is None:
            break  # stopped
        missing = frozenset(
            t.id
            for t in problem.tasks
            if problem.required(t) and t.id not in starts
        )
        if not missing:
            return []
        found.add(missing)
    return sorted(found, key=lambda names: (len(names), sorted(names)))


#: Bundles left out by the best plan that :func:`_bundles_first` tries
#: to place first, the most valuable first, and the rules it tries them
#: with (the two that placed the 13-task bundle below).
BUNDLES_TRIED = 3
BUNDLE_RULES = ("delay-rate", "deadline")


def bundles(problem: Problem) -> list[set[str]]:
    """Sets of two tasks or more tied by ``both`` or tight precedences:
    kept all together or (for ``both``) not at all, so a list schedule
    that cannot place one of them loses them all."""
    tied = [
        (prec.before, prec.after)
        for prec in problem.precedences
        if prec.scope == "both" or prec.kind == "tight"
    ]
    return [
        set(names)
        for names in linked((t.id for t in problem.tasks), tied)
        if len(names) > 1
    ]


def _bundles_first(
    problem: Problem,
    domains: dict[str, Domain],
    forced: Set[str],
    seeds: set[str],
    best: Plan,
    stop: Callable[[], bool] | None,
) -> list[Plan]:
    """Plans that place a bundle (:func:`bundles`) ``best`` left out
    wholly before every other task, if better than ``best``.

    Every rule places the tasks every plan must hold first, at their
    earliest: on a camera they can take the only slots a bundle's tasks
    have, and one task of the bundle not placed takes the bundle out.
    The large suite's b60-h1440 of seed 210 (60 tasks): every rule left
    out 31 tasks (26.3 M), 11 of them a bundle of 13 worth 41 units that
    CP-SAT keeps; placed first, 22 left out (16.5 M).
    """
    value = {t.id: t.schedule_cost for t in problem.tasks}
    left = set(best.unscheduled)
    out = sorted(
        (b for b in bundles(problem) if b <= left | forced and b & left),
        key=lambda b: (-sum(value[n] for n in b), min(b)),
    )
    found: list[Plan] = []
    for bundle in out[:BUNDLES_TRIED]:
        for name in BUNDLE_RULES:
            if stop is not None and stop():
                return found
            plan = _rule_plan(
                problem,
                RULES[name](problem, domains, forced),
                domains,
                seeds,
                stop=stop,
                first=bundle,
            )
            if (
                plan is not None
                and plan.objective is not None
                and best.objective is not None
                and plan.objective.total < best.objective.total
            ):
                found.append(plan)
    return found


def _forced_apart(
    problem: Problem, forced: Set[str], stop: Callable[[], bool] | None
) -> Plan | None:
    """The tasks every plan must hold planned alone, then the others
    around them where they stay; None if that fails too.

    The fallback of :func:`greedy_plan` when no rule placed the forced
    tasks among the others: in a replan, tasks running at its time are
    pinned there and one of them may need a generator beside it, which
    every rule booked after other tasks had taken its place (replan
    suite, seed 24's r60-h1440-0: no plan from the heuristic, none from
    CBC in 10 s; this way 17,788,561 in 0.3 s, CP-SAT's 17,784,616).
    """
    if len(forced) == problem.num_tasks:
        return None  # nothing else to plan apart from them
    core = _rules_only(forced_alone(problem, forced), stop)
    if core is None:
        return None
    return around_core(problem, core.starts(), stop)


def forced_alone(problem: Problem, forced: Set[str]) -> Problem:
    """The problem of the tasks ``forced`` alone (the precedences among
    them), their costs as they are (not :func:`~fsw_scheduler.analysis.
    bounds.kept_only`, which makes them mandatory and so changes the
    rules' order among them)."""
    return problem.replace(
        tasks=tuple(t for t in problem.tasks if t.id in forced),
        precedences=tuple(
            p
            for p in problem.precedences
            if p.before in forced and p.after in forced
        ),
        # The groups of the tasks kept, with the options wholly kept: no
        # group may name a task the sub-problem does not hold.
        alternatives=groups.kept_alternatives(problem, forced),
    )


def around_core(
    problem: Problem,
    core: dict[str, int],
    stop: Callable[[], bool] | None = None,
) -> Plan | None:
    """The tasks of ``core`` pinned at their starts there, the others
    list-scheduled around them where they fit; None if the checker
    refuses the plan (or no rule places the pinned tasks)."""
    around = _rules_only(problem.pinned(core), stop)
    if around is None:
        return None
    return checked_starts(problem, around.starts())


def checked_starts(problem: Problem, starts: dict[str, int]) -> Plan | None:
    """The plan of ``starts`` (every other task left out), status
    ``feasible`` with its objective, if the checker accepts it; else
    None."""
    plan = _as_plan(problem, starts)
    return plan if check_plan(problem, plan).ok else None


def _rules_only(
    problem: Problem, stop: Callable[[], bool] | None
) -> Plan | None:
    """:func:`greedy_plan` without its fallback (no second level)."""
    return greedy_plan(problem, stop=stop, apart=False)


def plan_in_order(
    problem: Problem, order: list[str], domains: dict[str, Domain]
) -> Plan | None:
    """The list schedule taking groups in ``order`` (task ids, first
    first; a group goes by its first member), not yet checked; None when
    a mandatory task cannot be placed."""
    rank = {name: k for k, name in enumerate(order)}
    seeds = conflict_seeds(problem, forced_tasks(problem))
    return _rule_plan(
        problem, lambda group: (-min(rank[n] for n in group),), domains, seeds
    )


def order_of(problem: Problem, plan: Plan) -> list[str]:
    """``plan``'s tasks by start (ties in problem order), then the tasks
    it leaves out, in problem order: the order whose list schedule
    (:func:`plan_in_order`) is ``plan`` or starts no task later."""
    starts = plan.starts()
    return sorted(
        (task.id for task in problem.tasks),
        key=lambda name: (name not in starts, starts.get(name, 0)),
    )


def placed_whole(
    problem: Problem, names: Sequence[str], domains: dict[str, Domain]
) -> Plan | None:
    """The first plan by the rules ``names`` (of :data:`~.rules.RULES`)
    that holds every task every plan of ``problem`` must hold, not yet
    checked; None when none does."""
    forced = forced_tasks(problem)
    seeds = conflict_seeds(problem, forced)
    for name in names:
        plan = _rule_plan(
            problem, RULES[name](problem, domains, forced), domains, seeds
        )
        if plan is not None:
            return plan
    return None


def _rule_plan(
    problem: Problem,
    priority: Callable[[dict[str, int]], tuple[Any, ...]],
    domains: dict[str, Domain],
    seeds: set[str],
    *,
    stop: Callable[[], bool] | None = None,
    first: set[str] | None = None,
) -> Plan | None:
    """A plan by list scheduling in ``priority`` order, not yet checked.

    Tasks that end up alone in a ``both`` precedence are dropped after the
    pass; since dropping a generator can starve a consumer placed after
    it, the pass is then run again with those tasks left out from the
    start, until nothing needs dropping (at most once per task). None when
    a mandatory task cannot be placed.

    Parameters
    ----------
    problem
        A validated problem.
    priority
        Key of a group (member id to start offset); the ready group with
        the highest key is placed next.
    domains
        The problem's :func:`start_domains`.
    seeds
        Tasks left out from the start.
    stop
        True when time is up: the pass is abandoned (None).
    first
        Place these tasks' groups first, the others after them.
    """
    excluded = set(seeds)
    for _ in range(problem.num_tasks + 1):
        found = _list_schedule(
            problem, excluded, priority, domains, stop=stop, first=first
        )
        if found is None:
            return None
        starts = found
        # Half options and rival options out: the next pass fills in.
        dropped = groups.keep_one_option(problem, starts)
        dropped |= _drop_unsupported(problem, starts)
        if any(
            problem.required(t) and t.id not in starts for t in problem.tasks
        ) or groups.mandatory_group_missing(problem, starts):
            return None
        if not dropped:
            break
        excluded |= dropped
    return _as_plan(problem, starts)


def _list_schedule(
    problem: Problem,
    excluded: set[str],
    priority: Callable[[dict[str, int]], tuple[Any, ...]],
    domains: dict[str, Domain],
    *,
    stop: Callable[[], bool] | None = None,
    first: set[str] | None = None,
) -> dict[str, int] | None:
    """One pass: each group in turn at its earliest fitting start.

    With ``first``, a first pass places only those tasks (the rest of
    their groups is left out) and a second pass the other groups. None
    when ``stop()`` turns true meanwhile.
    """
    tasks = {t.id: t for t in problem.tasks}
    groups = _tight_groups(problem)
    group_of = {name: idx for idx, g in enumerate(groups) for name in g}
    predecessors: dict[int, set[int]] = defaultdict(set)
    for prec in problem.precedences:
        a, b = group_of[prec.before], group_of[prec.after]
        if a != b:
            predecessors[b].add(a)
    board = Board(problem)
    starts: dict[str, int] = {}
    placed: set[int] = set()
    # A group's priority does not change during the pass: each key once
    # (asked at every choice, it was a tenth of a 15-task solve's time).
    # min(group) is the stable tie-break between equal priorities.
    keys = [(*priority(g), min(g)) for g in groups]
    for keep in (None,) if first is None else (first, None):
        decided = set(placed)
        remaining = set(range(len(groups))) - placed
        while remaining:
            if stop is not None and stop():
                return None
            ready = [g for g in remaining if predecessors[g] <= decided]
            if not ready:  # a precedence cycle between groups: break it
                ready = list(remaining)
            chosen = max(ready, key=keys.__getitem__)
            remaining.discard(chosen)
            decided.add(chosen)
            members = _without(problem, groups[chosen], excluded)
            if keep is not None:
                members = _without(problem, members, members.keys() - keep)
                if not members:
                    continue  # placed in the second pass
            placed.add(chosen)
            _place(problem, members, tasks, domains, board, starts)
    return starts


def _place(
    problem: Problem,
    members: dict[str, int],
    tasks: dict[str, Task],
    domains: dict[str, Domain],
    board: Board,
    starts: dict[str, int],
) -> None:
    """Book a group at its earliest fitting start, shedding if it must."""
    anchor = None
    while members:
        anchor = _earliest(problem, members, tasks, domains, board, starts)
        if anchor is not None:
            break
        # The whole group does not fit: shed its optional followers
        # (tight "at_least_first" successors) and try the rest.
        optional = {
            prec.after
            for prec in problem.precedences
            if prec.kind == "tight"
            and prec.scope == "at_least_first"
            and prec.before in members
            and prec.after in members
        }
        if not optional:
            break
        members = _without(problem, members, optional)
        parts = _split(problem, members)
        if len(parts) > 1:
            # Shedding cut the group: a follower tied two chains that
            # cannot run at those offsets (b15-all-6 of broad seed 15: a
            # shared tight successor of a long task and of a chain whose
            # short task the long one overlaps). Each chain alone may fit.
            for part in parts:
                _place(problem, part, tasks, domains, board, starts)
            return
    if anchor is None:
        return
    for name, shift in members.items():
        starts[name] = anchor + shift
        board.add(tasks[name], anchor + shift)


def _split(problem: Problem, members: dict[str, int]) -> list[dict[str, int]]:
    """``members`` in their tight-connected parts (tight precedences
    between members only), each with its shifts from its own first start,
    in an order no precedence between parts goes against (the original
    order of the shifts where none decides; one part when they form a
    cycle)."""
    inside = [
        p
        for p in problem.precedences
        if p.before in members and p.after in members
    ]
    sets = linked(
        (n for n, _ in sorted(members.items(), key=lambda m: (m[1], m[0]))),
        [(p.before, p.after) for p in inside if p.kind == "tight"],
    )
    if len(sets) == 1:
        return [members]
    part_of = {name: k for k, names in enumerate(sets) for name in names}
    waiting = [
        {part_of[p.before] for p in inside if part_of[p.after] == k} - {k}
        for k in range(len(sets))
    ]
    order: list[int] = []
    while len(order) < len(sets):
        ready = [
            k
            for k in range(len(sets))
            if k not in order and waiting[k] <= set(order)
        ]
        if not ready:
            return [members]
        order.append(ready[0])
    parts = []
    for k in order:
        low = min(members[n] for n in sets[k])
        parts.append({n: members[n] - low for n in sets[k]})
    return parts


def _without(
    problem: Problem, members: dict[str, int], drop: Set[str]
) -> dict[str, int]:
    """``members`` less ``drop`` and every member that cannot go without it.

    A member goes when a precedence makes it follow a dropped task, or
    when it is the first of a ``both`` precedence whose second is dropped.
    """
    gone = drop & members.keys()
    if not gone:
        return members
    changed = True
    while changed:
        changed = False
        for prec in problem.precedences:
            if prec.before in gone and prec.after in members:
                changed |= prec.after not in gone
                gone.add(prec.after)
            if (
                prec.scope == "both"
                and prec.after in gone
                and prec.before in members
            ):
                changed |= prec.before not in gone
                gone.add(prec.before)
    return {n: s for n, s in members.items() if n not in gone}


def _earliest(
    problem: Problem,
    group: dict[str, int],
    tasks: dict[str, Task],
    domains: dict[str, Domain],
    board: Board,
    starts: dict[str, int],
) -> int | None:
    """Earliest anchor at which every member of ``group`` fits."""
    low, high = problem.start, problem.end
    for name, shift in group.items():
        domain = domains[name]
        if domain.empty:
            return None
        low = max(low, domain.earliest - shift)
        high = min(high, domain.latest - shift)
    for prec in problem.precedences:
        if prec.after not in group or prec.before in group:
            continue
        before = starts.get(prec.before)
        if before is None:
            return None  # both scopes need the first task
        gap = tasks[prec.before].length + prec.offset
        bound = before + gap - group[prec.after]
        low = max(low, bound)
        if prec.kind == "tight":
            high = min(high, bound)
    if len(group) == 1:
        ((name, shift),) = group.items()
        found = board.first_fit(tasks[name], low + shift, high + shift)
        return None if found is None else found - shift
    # The group's demand at anchor ``problem.start``, moved to each anchor.
    shape = board.demand(
        [(tasks[name], problem.start + shift) for name, shift in group.items()]
    )
    found = board.first_fit_demand(
        shape, low - problem.start, high - problem.start
    )
    return None if found is None else found + problem.start


def _drop_unsupported(problem: Problem, starts: dict[str, int]) -> set[str]:
    """Unschedule tasks whose precedence partner is missing; return them.

    A ``before`` task of a ``both`` precedence needs its ``after`` task;
    any ``after`` task needs its ``before`` task.
    """
    dropped: set[str] = set()
    changed = True
    while changed:
        changed = False
        for prec in problem.precedences:
            if (
                prec.scope == "both"
                and prec.before in starts
                and prec.after not in starts
            ):
                del starts[prec.before]
                dropped.add(prec.before)
                changed = True
            elif prec.after in starts and prec.before not in starts:
                del starts[prec.after]
                dropped.add(prec.after)
                changed = True
    return dropped


def _as_plan(problem: Problem, starts: dict[str, int]) -> Plan:
    activities = sorted(
        (
            Activity(t.id, starts[t.id], starts[t.id] + t.length)
            for t in problem.tasks
            if t.id in starts
        ),
        key=lambda a: (a.start, a.task),
    )
    return Plan(
        status=SolveStatus.FEASIBLE,
        objective=_objective(problem, starts),
        activities=tuple(activities),
        unscheduled=groups.left_out(problem, starts),
        chosen=groups.chosen(problem, starts),
    )


def _objective(problem: Problem, starts: dict[str, int]) -> Objective:
    missed = groups.unscheduled_cost(problem, starts)
    delay = sum(
        t.delay_cost * (starts[t.id] - problem.start)
        for t in problem.tasks
        if t.id in starts
    )
    weight = objective_weight(
        [t.delay_cost for t in problem.tasks], problem.horizon
    )
    return Objective(missed, delay, weight * missed + delay)
