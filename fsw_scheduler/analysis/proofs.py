"""Cheap infeasibility proofs and the tasks every plan must hold (pure).

A problem is infeasible only when the tasks that every plan must schedule
cannot all be placed. Those are the *forced* tasks (:func:`forced_tasks`):
the mandatory ones, every task a forced task needs (its ``before`` in any
precedence) and every task a forced task drags in (its ``after`` in a
``both`` precedence). Anything else may be left out, so a contradiction
elsewhere only means that some tasks cannot be scheduled together, which
the model and the heuristic handle by leaving one of them out.

:func:`infeasibility` looks for a proof among the forced tasks alone,
without a solver, in time polynomial in their number:

* a forced task without a start time (``window``, ``precedence`` or
  ``consumable``, from :func:`fsw_scheduler.analysis.domains.start_domains`);
* tight precedences among forced tasks that fix the same start difference
  in two different ways (:func:`tight_conflicts`);
* binary and multiple resources: over an interval ``[a, b)``, the work
  forced tasks must do inside it (each at its least overlap, whatever its
  start in its domain) exceeding ``capacity x (b - a)``: the energetic
  test of cumulative scheduling, which also covers a task that alone
  needs more than the capacity;
* sets of forced tasks no two of which can run at once (a binary
  resource both use, or a multiple one whose capacity their two uses
  exceed, such as tasks each needing more than half of it): the same
  energetic test, one task at a time, over cliques of that "apart"
  relation (:func:`apart_cliques`), which catches what the per-resource
  test cannot (five tasks each needing 60 % of a capacity in a window
  shorter than their total length need only 3 lengths of energy);
* the same for "at most m at once" on a multiple resource: the forced
  users of which no m + 1 fit in its capacity together (five tasks each
  needing 34 % of it run at most two at a time) need their least
  overlaps with ``[a, b)`` to fit in m lanes of ``b - a`` units
  (:func:`~fsw_scheduler.analysis.lanes.crowded`);
* consumables (:mod:`~fsw_scheduler.analysis.stores`): by the end of the
  latest possible end of some forced consumers, their consumption
  exceeding the initial level plus all the generation any task could
  have delivered by then; a forced consumer taking more in its run than
  a store with a capacity holds plus what can come in meanwhile.

Each proof is reported as :class:`~fsw_scheduler.model.plan.Blocker`\\ s
naming the tasks and the constraint.

:func:`block_conflicts` proves single tasks impossible instead: the tasks
that scheduling one task forces in, held at fixed offsets by tight
precedences, may overlap on a resource or contradict themselves. Those
tasks get an empty start domain
(:func:`fsw_scheduler.analysis.domains.start_domains`), so the model never
holds them and the proof above sees a forced one among them.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, NamedTuple

from ..model.plan import Blocker
from . import stores
from .lanes import crowded, least_overlaps, overloaded, room

if TYPE_CHECKING:
    from collections.abc import Callable, Collection, Mapping, Set

    from ..model.problem import Precedence, Problem, Task
    from .domains import Domain

_EPS = 1e-9


def forced_tasks(problem: Problem) -> set[str]:
    """Tasks that every valid plan schedules.

    The required tasks (:meth:`Problem.required`: a member of a group is
    not, one by one), closed under "needs" (:func:`with_needs`).
    """
    return with_needs(
        problem, {task.id for task in problem.tasks if problem.required(task)}
    )


def with_needs(problem: Problem, names: Set[str]) -> set[str]:
    """``names`` and every task a plan scheduling them must schedule too.

    The closure under "needs": the ``before`` of any precedence whose
    ``after`` is in it, the ``after`` of a ``both`` precedence whose
    ``before`` is, and the other tasks of a member's option. A
    sub-problem of a set so closed keeps every rule that binds its tasks
    to the others: a plan of it holds on ``problem`` with the others left
    out.
    """
    needed = set(names)
    index = problem.groups
    present = {task.id for task in problem.tasks}
    changed = bool(needed)
    while changed:
        changed = False
        for name in list(needed):
            for partner in index.partners(name):
                if partner in present and partner not in needed:
                    needed.add(partner)
                    changed = True
        for prec in problem.precedences:
            if prec.after in needed and prec.before not in needed:
                needed.add(prec.before)
                changed = True
            if (
                prec.scope == "both"
                and prec.before in needed
                and prec.after not in needed
            ):
                needed.add(prec.after)
                changed = True
    return needed


class TightConflict(NamedTuple):
    """A tight precedence that contradicts earlier ones.

    ``position`` is its index in ``problem.precedences``; it needs
    ``start(after) - start(before) = gap`` where the earlier tight
    precedences already imply ``implied``.
    """

    position: int
    prec: Precedence
    gap: int
    implied: int


def tight_conflicts(
    problem: Problem, among: Collection[str] | None = None
) -> list[TightConflict]:
    """Tight precedences whose fixed start differences contradict.

    A weighted union-find keeps, for each task, its start offset from the
    root of its tight group; a new tight precedence inside a group must
    agree with the offset already implied. Only precedences with both ends
    in ``among`` are considered (default: all).
    """
    length = {task.id: task.length for task in problem.tasks}
    parent: dict[str, str] = {}
    shift: dict[str, int] = {}  # s_task - s_parent

    def find(name: str) -> tuple[str, int]:
        total = 0
        while parent.get(name, name) != name:
            total += shift[name]
            name = parent[name]
        return name, total

    conflicts = []
    for idx, prec in enumerate(problem.precedences):
        if prec.kind != "tight":
            continue
        if among is not None and (
            prec.before not in among or prec.after not in among
        ):
            continue
        gap = length[prec.before] + prec.offset  # s_after - s_before
        root_b, off_b = find(prec.before)
        root_a, off_a = find(prec.after)
        if root_b == root_a:
            if off_a - off_b != gap:
                conflicts.append(TightConflict(idx, prec, gap, off_a - off_b))
            continue
        parent[root_a] = root_b
        shift[root_a] = off_b + gap - off_a
    return conflicts


def conflict_seeds(problem: Problem, forced: Set[str]) -> set[str]:
    """Tasks to leave out so that no tight precedences contradict.

    Tight precedences fixing the same start difference in two ways cannot
    all hold; of each such precedence the ``after`` task is left out (the
    ``before`` when ``after`` must be scheduled). The list scheduler of
    :mod:`~fsw_scheduler.analysis.greedy` leaves these out and groups
    tasks ignoring the same precedences.
    """
    seeds = set()
    for conflict in tight_conflicts(problem):
        prec = conflict.prec
        if prec.before in seeds or prec.after in seeds:
            continue
        seeds.add(prec.before if prec.after in forced else prec.after)
    return seeds


def block_conflicts(problem: Problem) -> dict[str, tuple[str, str]]:
    """Tasks that can never be scheduled, with the cause and why.

    Scheduling a task ``x`` schedules its *companions*: the ``before`` of
    every precedence whose ``after`` is scheduled and the ``after`` of
    every ``both`` precedence whose ``before`` is. Every precedence with
    both ends among them then binds, so the tight ones fix the start
    differences inside each tight-connected *block* of companions (the
    model's tight rows are exact once both tasks are scheduled, whatever
    the scope). ``x`` is impossible when a block

    * fixes a start difference in two ways, or breaks a lax precedence
      between two of its members (``precedence``);
    * has two members overlapping on a binary resource (``binary``);
    * has members whose simultaneous uses of a multiple resource exceed
      its capacity (``multiple``).

    Tasks every plan holds (:func:`forced_tasks`) are scheduled beside
    ``x`` too: where none of the above holds of ``x``'s companions alone,
    the blocks are formed again with those of them that tight
    precedences link to the companions (a task fixed 4 units after
    a mandatory one, whose other tight successor, mandatory too, starts
    2 units later on the same camera, can never be scheduled; CP-SAT
    proves such a problem at once, and CBC's model did not in 30 s).
    When the tasks every plan holds conflict among themselves, the
    problem is infeasible (:func:`infeasibility` says why) and they are
    not added.

    None of this depends on windows or the horizon: it holds for every
    start, so it is a proof, found in time linear in the precedences per
    task.

    Returns
    -------
    dict[str, tuple[str, str]]
        Task id to ``(cause, detail)``, in problem task order.
    """
    if not any(prec.kind == "tight" for prec in problem.precedences):
        return {}
    tasks = {task.id: task for task in problem.tasks}
    needs = precedence_needs(problem)
    found: dict[str, tuple[str, str]] = {}
    seen: dict[frozenset[str], tuple[str, str] | None] = {}

    def conflict(companions: set[str]) -> tuple[str, str] | None:
        key = frozenset(companions)
        if key not in seen:
            seen[key] = block_conflict(problem, tasks, companions)
        return seen[key]

    always = forced_tasks(problem)
    if always and conflict(always) is not None:
        always = set()  # infeasible: said by infeasibility(), not here
    tight: dict[str, list[str]] = {}
    for prec in problem.precedences:
        if prec.kind == "tight":
            tight.setdefault(prec.before, []).append(prec.after)
            tight.setdefault(prec.after, []).append(prec.before)
    for task in problem.tasks:
        companions = reach({task.id}, needs)
        clash = conflict(companions)
        if clash is not None:
            cause, detail = clash
            found[task.id] = (cause, f"{detail}; scheduling it needs them")
            continue
        beside = reach(companions, tight, within=always) - companions
        if not beside:
            continue
        clash = conflict(companions | beside)
        if clash is not None:
            cause, detail = clash
            found[task.id] = (
                cause,
                f"{detail}; every plan holds {', '.join(sorted(beside))}",
            )
    return found


def precedence_needs(problem: Problem) -> dict[str, list[str]]:
    """Each task's precedence partners it cannot be scheduled without:
    the ``before`` of each precedence it follows, the ``after`` of each
    ``both`` one it leads (a list per task id, in precedence order)."""
    needs: dict[str, list[str]] = {task.id: [] for task in problem.tasks}
    for prec in problem.precedences:
        needs[prec.after].append(prec.before)
        if prec.scope == "both":
            needs[prec.before].append(prec.after)
    return needs


def reach(
    start: Set[str],
    links: Mapping[str, list[str]],
    within: Set[str] | None = None,
) -> set[str]:
    """``start`` and every task ``links`` lead to from it, directly or
    through one another; with ``within``, only through tasks of it."""
    reached = set(start)
    frontier = list(start)
    while frontier:
        for other in links.get(frontier.pop(), ()):
            if other not in reached and (within is None or other in within):
                reached.add(other)
                frontier.append(other)
    return reached


def block_conflict(
    problem: Problem, tasks: Mapping[str, Task], companions: Set[str]
) -> tuple[str, str] | None:
    """Why the tight blocks of ``companions`` cannot hold, or None."""
    clash = tight_conflicts(problem, companions)
    if clash:
        prec = clash[0].prec
        return (
            "precedence",
            f"tight precedences contradict: they fix "
            f"start({prec.after}) - start({prec.before}) to both "
            f"{clash[0].gap} and "
            f"{clash[0].implied}",
        )
    blocks = _blocks(problem, companions)
    if not blocks:
        return None
    block_of = {name: idx for idx, b in enumerate(blocks) for name in b}
    for prec in problem.precedences:
        if prec.kind != "lax" or prec.before not in companions:
            continue
        idx = block_of.get(prec.before)
        if idx is None or block_of.get(prec.after) != idx:
            continue
        gap = tasks[prec.before].length + prec.offset
        fixed = blocks[idx][prec.after] - blocks[idx][prec.before]
        if fixed < gap:
            return (
                "precedence",
                f"tight precedences fix start({prec.after}) - "
                f"start({prec.before}) = {fixed}, a lax one needs at "
                f"least {gap}",
            )
    res = problem.resources
    # The largest capacity a resource ever has: a block over it is over
    # every capacity the resource has at any time.
    capacities = {
        name: res.peak_capacity(name) for name in (*res.binary, *res.multiple)
    }
    for block in blocks:
        for name, capacity in capacities.items():
            users = sorted(
                (block[n], n) for n in block if tasks[n].uses.get(name, 0) > 0
            )
            if len(users) < 2:
                continue
            # Sweep the fixed intervals: the use peaks at some start.
            for offset, _ in users:
                running = [
                    n
                    for start, n in users
                    if start <= offset < start + tasks[n].length
                ]
                total = sum(tasks[n].uses[name] for n in running)
                if total > capacity + _EPS:
                    kind = res.kind_of(name) or "multiple"
                    what = (
                        f"{' and '.join(running)} overlap on {name}"
                        if kind == "binary"
                        else f"{', '.join(running)} use {total:g} {name} "
                        f"at once, over its capacity {capacity:g}"
                    )
                    return (
                        kind,
                        f"tight precedences fix the starts of "
                        f"{', '.join(sorted(block))} so that {what}",
                    )
    return None


def _blocks(problem: Problem, among: Set[str]) -> list[dict[str, int]]:
    """Tight-connected groups of ``among`` (two or more tasks), each with
    its members' start offsets from its first member.

    Only meaningful when :func:`tight_conflicts` finds none among them.
    """
    length = {task.id: task.length for task in problem.tasks}
    links: dict[str, list[tuple[str, int]]] = {}
    for prec in problem.precedences:
        if (
            prec.kind == "tight"
            and prec.before in among
            and prec.after in among
        ):
            gap = length[prec.before] + prec.offset
            links.setdefault(prec.before, []).append((prec.after, gap))
            links.setdefault(prec.after, []).append((prec.before, -gap))
    blocks: list[dict[str, int]] = []
    placed: set[str] = set()
    for task in problem.tasks:
        if task.id not in links or task.id in placed:
            continue
        block = {task.id: 0}
        frontier = [task.id]
        while frontier:
            name = frontier.pop()
            for other, gap in links[name]:
                if other not in block:
                    block[other] = block[name] + gap
                    frontier.append(other)
        placed |= block.keys()
        blocks.append(block)
    return blocks


def infeasibility(
    problem: Problem,
    domains: Mapping[str, Domain],
    stop: Callable[[], bool] | None = None,
) -> tuple[Blocker, ...]:
    """A proof that the forced tasks cannot all be placed, or ``()``.

    Parameters
    ----------
    problem
        A validated problem.
    domains
        Its :func:`~fsw_scheduler.analysis.domains.start_domains`.
    stop
        True when time is up (the caller's deadline: this module reads no
        clock): the interval sweeps end there without a proof.

    Returns
    -------
    tuple[Blocker, ...]
        The forced tasks concerned and the constraint that excludes them;
        empty when no cheap proof exists (the problem may still be
        infeasible) or ``stop`` ended the search first.
    """
    drained = stores.drain(problem, domains)
    if drained:
        return drained
    forced = forced_tasks(problem)
    if not forced:
        return ()
    tasks = [task for task in problem.tasks if task.id in forced]
    stuck = tuple(
        Blocker(task.id, domains[task.id].cause, domains[task.id].detail)
        for task in tasks
        if domains[task.id].empty
    )
    if stuck:
        return stuck
    for conflict in tight_conflicts(problem, forced):
        prec = conflict.prec
        detail = (
            f"tight precedences among tasks that must be scheduled "
            f"contradict: precedences[{conflict.position}] needs "
            f"start({prec.after}) - start({prec.before}) = {conflict.gap}, "
            f"others imply {conflict.implied}"
        )
        return (
            Blocker(prec.before, "precedence", detail),
            Blocker(prec.after, "precedence", detail),
        )
    res = problem.resources
    for name in (*res.binary, *res.multiple):
        profile = res.capacity_profile(name, problem.start, problem.horizon)
        found = _energy(problem, tasks, domains, name, profile, stop)
        if found:
            return found
    found = _apart_overload(problem, tasks, domains, stop)
    if found:
        return found
    for name in res.multiple:
        profile = res.capacity_profile(name, problem.start, problem.horizon)
        found = crowded(problem, tasks, domains, name, profile, stop)
        if found:
            return found
    for name, initial in res.initial_levels.items():
        found = stores.budget(problem, tasks, domains, name, initial)
        if found:
            return found
        found = stores.store(problem, tasks, domains, name)
        if found:
            return found
    return ()


def _energy(
    problem: Problem,
    forced: list[Task],
    domains: Mapping[str, Domain],
    resource: str,
    profile: list[float],
    stop: Callable[[], bool] | None = None,
) -> tuple[Blocker, ...]:
    """Energetic test of one capacity resource over the forced users.

    ``profile`` is the capacity of each unit from the problem's start
    (windows and steps): the work an interval allows is its integral.
    """
    kind = problem.resources.kind_of(resource)
    capacity = max(profile, default=0.0)
    # allowed[k]: capacity summed over the units before start + k.
    allowed = list(itertools.accumulate(profile, initial=0.0))
    users = [
        (task, task.uses[resource], domains[task.id])
        for task in forced
        if task.uses.get(resource, 0) > 0
    ]
    for task, amount, _ in users:
        if amount > capacity + _EPS:
            return (
                Blocker(
                    task.id,
                    kind or "multiple",
                    f"needs {amount:g} {resource}, more than its capacity "
                    f"{capacity:g}",
                ),
            )
    if sum(a * t.length for t, a, _ in users) <= min(profile, default=0.0):
        return ()  # not even two units of work: nothing to find
    amounts = {task.id: amount for task, amount, _ in users}
    spans = [(task, dom) for task, _, dom in users]
    for low, high, inside, pieces in least_overlaps(spans, stop):
        need = sum(
            amounts[name] * piece
            for name, piece in zip(inside, pieces, strict=True)
        )
        space = room(problem, allowed, low, high)
        if need > space + _EPS:
            detail = (
                f"{resource}: tasks that must be scheduled need "
                f"{need:g} units of work in [{low}, {high}), where "
                f"capacity {_capacity_words(profile)} allows {space:g}"
            )
            return tuple(
                Blocker(name, kind or "multiple", detail) for name in inside
            )
    return ()


def _capacity_words(profile: list[float]) -> str:
    """``4`` for a constant capacity, ``0..4`` for one that changes."""
    low, high = min(profile, default=0.0), max(profile, default=0.0)
    return f"{high:g}" if low == high else f"{low:g}..{high:g}"


#: Cliques grown from single tasks (beyond one per resource) are tried
#: only among at most this many forced resource users: each check costs
#: the cube of the clique's size.
MAX_SEEDED_USERS = 120


def apart_cliques(
    problem: Problem, tasks: Collection[Task]
) -> list[tuple[list[Task], str]]:
    """Sets of ``tasks`` no two of which can run at the same time.

    Two tasks are *apart* when a binary resource is used by both, or a
    multiple resource's capacity is less than their two uses together.
    Cliques of that relation are found greedily (a maximum clique is
    NP-hard, and any clique gives a valid test): one per capacity
    resource, its users by decreasing use (every user above half the
    capacity first, which are all pairwise apart), then one from each
    task; each is extended by the tasks apart from all its members, the
    longest first. Subsets of a clique already found are dropped.

    Returns
    -------
    list[tuple[list[Task], str]]
        Cliques of two or more tasks, in a fixed order, each with the kind
        of resource that keeps its members apart (``multiple`` when any
        pair is apart only on a multiple resource, else ``binary``).
    """
    res = problem.resources
    users = [
        task
        for task in tasks
        if any(
            task.uses.get(name, 0) > 0 for name in (*res.binary, *res.multiple)
        )
    ]
    apart: dict[str, dict[str, str]] = {task.id: {} for task in users}
    for idx, one in enumerate(users):
        for other in users[idx + 1 :]:
            kind = _apart(problem, one, other)
            if kind is not None:
                apart[one.id][other.id] = apart[other.id][one.id] = kind
    by_length = sorted(users, key=lambda t: (-t.length, t.id))

    def grown(seed: list[Task]) -> list[Task]:
        clique: list[Task] = []
        members: set[str] = set()
        for task in [*seed, *by_length]:
            if task.id not in members and members <= apart[task.id].keys():
                clique.append(task)
                members.add(task.id)
        return clique

    seeds: list[list[Task]] = []
    for name in (*res.binary, *res.multiple):
        ranked = sorted(
            (t for t in users if t.uses.get(name, 0) > 0),
            key=lambda t: (-t.uses[name], -t.length, t.id),
        )
        seeds.append(ranked)
    if len(users) <= MAX_SEEDED_USERS:
        seeds.extend([task] for task in by_length)
    found: list[tuple[list[Task], str]] = []
    seen: list[frozenset[str]] = []
    for seed in seeds:
        clique = grown(seed)
        key = frozenset(t.id for t in clique)
        if len(clique) < 2 or any(key <= other for other in seen):
            continue
        seen.append(key)
        kinds = {
            apart[a.id][b.id]
            for idx, a in enumerate(clique)
            for b in clique[idx + 1 :]
        }
        found.append((clique, "multiple" if "multiple" in kinds else "binary"))
    return found


def _apart(problem: Problem, one: Task, other: Task) -> str | None:
    """The kind of resource on which ``one`` and ``other`` cannot run at
    once (``binary`` first), or None."""
    res = problem.resources
    for name in res.binary:
        if one.uses.get(name, 0) > 0 and other.uses.get(name, 0) > 0:
            return "binary"
    for name in res.multiple:
        # The peak: over it the two never run at once, at any time.
        capacity = res.peak_capacity(name)
        first, second = one.uses.get(name, 0), other.uses.get(name, 0)
        if first > 0 and second > 0 and first + second > capacity + _EPS:
            return "multiple"
    return None


def _apart_overload(
    problem: Problem,
    forced: list[Task],
    domains: Mapping[str, Domain],
    stop: Callable[[], bool] | None = None,
) -> tuple[Blocker, ...]:
    """The energetic test of one task at a time over each clique of forced
    tasks that pairwise cannot overlap (:func:`apart_cliques`).

    Over ``[low, high)`` the clique's members must run, one after the
    other, at least their least overlap with it whatever their starts:
    more than ``high - low`` in all cannot be. Interval ends are those of
    :func:`_energy`.
    """
    binary_users = [
        {task.id for task in forced if task.uses.get(name, 0) > 0}
        for name in problem.resources.binary
    ]
    one_lane = list(range(problem.horizon + 1))  # one unit per unit
    for clique, kind in apart_cliques(problem, forced):
        ids = {task.id for task in clique}
        if any(ids <= users for users in binary_users):
            continue  # :func:`_energy` tested all of them on that resource
        members = [(task, domains[task.id]) for task in clique]
        found = overloaded(problem, members, one_lane, stop)
        if found is not None:
            inside, need, low, high, _ = found
            detail = (
                f"{', '.join(inside)} must be scheduled and no two "
                f"can run at once ({kind} resources), but need "
                f"{need} time units in [{low}, {high}), which has "
                f"{room(problem, one_lane, low, high)}"
            )
            return tuple(Blocker(name, kind, detail) for name in inside)
    return ()
