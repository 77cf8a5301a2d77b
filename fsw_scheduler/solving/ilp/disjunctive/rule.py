"""Which formulation to build for a part, and when a disjunctive run yields.

:func:`pick` picks the disjunctive model of
:mod:`fsw_scheduler.solving.ilp.disjunctive` where the time-indexed model is
weak: parts whose hard part is sharing binary or multiple resources. The
time-indexed model's root LP there is large and degenerate (n = 15,
binary: 0.59 of 0.72 s in a 4,924 x 2,669 LP whose MIP start was already
optimal), while the disjunctive model has a few columns per task and one
pair of order binaries per pair of users that may collide. The
time-indexed model is kept

* for consumables: levels over time are what its rows express, and the
  disjunctive model has none;
* for consumables with an external rate, and for parts whose binary
  windows and capacity steps in use make more than
  :data:`~.blocks.MAX_BLOCKS` blocks (:func:`.blocks.modelled`): the
  disjunctive model reads one capacity per resource, and holds a
  changing one by pinned tasks of its own (:mod:`.blocks`), each a user
  of its resource, where the time-indexed model has a row per unit with
  that unit's capacity;
* for multiple resources where almost every set of users over a
  capacity needs three or more of them (pairs under
  :data:`MIN_PAIR_SHARE` of the :func:`minimal_sets` of the part's
  multiple resources), or one that has more than :data:`MAX_USERS`
  users and is not :func:`pairwise_exact`. The disjunctive model
  handles sets beyond pairs with load rows at each start (see
  :mod:`.constraints`), whose LP says little when pairs are rare.

Measured through :func:`~fsw_scheduler.solving.solve.solve` (greedy MIP
start, cost caps, :data:`~fsw_scheduler.solving.ilp.progress.\
WITH_START_DISJUNCTIVE`, 10 s limit) with each model forced on the 84
15-task multiple problems of ``tools/bench --generator paper|broad
--seed 0..5 --only c15-multiple|b15-multiple`` (none pairwise exact):
always time-indexed (the earlier rule) took 66.9 s in total, always
disjunctive 84.0 s (3 not proved), the better of the two each time
44.8 s. Picking the disjunctive model from a pair share of 0.10 took
47.9 s (0.08-0.12: 46.8-47.9 s; 0.06: 52.0 s; 0.02: 79.1 s), the worst
solve 7.7 s instead of 8.8 s, every problem proved. Above 0.12 the
disjunctive model won 26 of 31 (c15-multiple-0 of seed 0: 2.2 s
against 8.8 s, not proved); under 0.06 the time-indexed one won 30 of
44. On seeds 6 and 7 (not looked at before) the mean per broad problem
went 0.78 -> 0.43 s and 2.51 -> 2.19 s, the paper ones stayed at
0.03-0.06 s.

For binary resources the same command (``--only b15-binary``) gave a
median of 2.07 s, 100.5x CP-SAT and 5/7 proved for the time-indexed
model, 0.34 s, 28.4x and 7/7 for the disjunctive one.

A part with no resource in use (precedences and windows only) gets the
disjunctive model too: the time-indexed model's LP is tight there, but
it has a column per task and start time and a row per precedence and
unit, where the disjunctive one has a few columns per task and a row
per precedence. Measured through
:func:`~fsw_scheduler.solving.solve.solve` (30 s limit, median of 3
solves each), time-indexed against disjunctive, on problems not looked
at before: the 28 15-task ``none`` problems of seeds 91 and 93 (both
generators) 0.23 -> 0.14 s in total (paper seed 91's c15-none-6 0.052
-> 0.009 s); the 84 ``none`` problems of 5-15 tasks of seeds 94-95,
0.32 -> 0.23 s, none slower than 0.02 s; 24 problems of 20-29 tasks at
H = 336 and 1440 built by the campaign's generators with no resource,
0.29 -> 0.16 s (n25-h1440 0.049 -> 0.010 s). The same objectives
everywhere; the one problem slower by more than a few milliseconds
went 0.012 -> 0.021 s.

A disjunctive run on a small part with a multiple resource that has not
proved its answer after :data:`SWITCH_NODES_MULTIPLE_ONLY` nodes (with a
binary resource in use as well, :data:`SWITCH_NODES`) goes on in the
time-indexed model from its best plan (:func:`switch_nodes`; the run
itself is in :mod:`fsw_scheduler.solving.ilp.model`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from ....analysis.domains import start_count
from .blocks import modelled

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ....analysis.domains import Domain
    from ....model.problem import Problem, ResourceKind

#: Below this share of pairs among the minimal sets of two or three users
#: over the part's multiple capacities, the time-indexed model is built
#: (measured: see the module docstring).
MIN_PAIR_SHARE = 0.10

#: A multiple resource with more users than this (not pairwise exact)
#: keeps the time-indexed model: counting its sets of three would cost
#: more than it tells, and no measurement covers such parts.
MAX_USERS = 40

#: Search nodes after which a disjunctive run on a part with a multiple
#: resource in use hands over to the time-indexed model
#: (:func:`switch_nodes`). Measured (with CBC's mini branch-and-bound
#: off, :data:`~fsw_scheduler.solving.ilp.model.DISJUNCTIVE_STRONG`) on
#: the 22 disjunctive parts of ``tools/bench --generator broad --seed
#: 32..39 --only b15-multiple``, in total: no switch 23.8 s, 1,000 nodes
#: 15.0 s (one part 0.60 -> 2.9 s), 2,000 nodes 15.6 s, 5,000 nodes
#: 16.7 s with no part slower; seed 32's b15-multiple-3, unproved at a
#: 20 s limit, proved in 11.7 s (the time-indexed model alone: 8.1 s).
#: Where the disjunctive model won, it proved in at most about 2,000
#: nodes. On seeds not looked at (40-45 broad, 40-42 paper; 38 parts of
#: 10 and 15 tasks) no part switched and the total stayed within a
#: rerun's spread (3.64 -> 3.57 s).
SWITCH_NODES = 5_000

#: Search nodes after which a disjunctive run hands over when the part's
#: only shared resources are multiple ones (no binary resource in use):
#: the time-indexed model has no binary resource to make its LP large
#: and degenerate there, and its LP closes in a few nodes what the
#: disjunctive search runs thousands on. Measured through
#: :func:`~fsw_scheduler.solving.solve.solve` (10 s limit) on the 52
#: 15-task multiple problems of ``tools/bench --generator paper|broad
#: --only 15-mult`` seeds 0-5 and 121-126 whose part the rule gave the
#: disjunctive model, in total: 5,000 nodes 34.5 s, 1,000 nodes 27.4 s,
#: 500 nodes 25.1 s, 200 nodes 27.1 s; 25 parts under 50 ms against 23
#: (paper seed 121's c15-multiple-0: 0.96 -> 0.16 s; the time-indexed
#: model proves it at its root). On seeds 127-132 (not looked at
#: before; 30 such parts) 17.2 -> 16.0 s: three parts faster by more
#: than 0.1 s (paper seed 128's c15-multiple-0 3.26 -> 1.73 s), three
#: slower (broad seed 127's b15-multiple-6 0.22 -> 0.64 s: the
#: disjunctive model would have proved it within 5,000 nodes), the
#: other 24 within 0.1 s; the same optima. With a binary resource in
#: use as well the time-indexed model stays slow (``tools/fuzz`` seed
#: 20084, a 19-task part with cameras and two power resources: proved
#: in 2.2 s with 5,000 nodes, 6.0 s with 500), so :data:`SWITCH_NODES`
#: holds there; ``tools/fuzz --first 21000 --count 60`` gave the same
#: answers before and after.
SWITCH_NODES_MULTIPLE_ONLY = 500

#: A part of more tasks than the switch's measured sizes (the caller's
#: ``max_tasks``) switches too when its time-indexed model has at most
#: this many columns (start times): the model is then as small as a
#: 15-task part's (the root probe's threshold, :data:`~fsw_scheduler.
#: solving.incumbent.ROOT_PROBE_COLUMNS`). A 16-task part over H = 60
#: with a camera and a multiple resource of capacity 3 (about 900
#: columns) ran the disjunctive model to the end of a 30 s limit
#: unproved (27 s to prove it alone); the time-indexed model proves it
#: in 1.4 s.
SWITCH_COLUMNS = 5_000

#: The same for a larger part with a binary resource in use as well,
#: whose time-indexed model is slow past a few thousand columns (its LP
#: large and degenerate, see the module docstring): ``tools/fuzz`` seed
#: 19040, a 20-task part with a camera and two power resources (3,835
#: columns), switched after 5,000 nodes (3.6 s) and was not proved in
#: the time-indexed model by the end of 20 s (`feasible` 4,255); the
#: disjunctive model alone proves it, 4,219, in 5.5 s. The 16-task
#: part above has about 800 columns. Of the 24 parts with a camera and
#: a multiple resource that the disjunctive model took in ``tools/fuzz
#: --first 19000 --count 300``, that was the one that switched.
SWITCH_COLUMNS_BINARY = 2_000

Formulation = Literal["time-indexed", "disjunctive"]
FORMULATIONS: tuple[Formulation, ...] = ("time-indexed", "disjunctive")


def pairwise_exact(amounts: list[float], capacity: float) -> bool:
    """True if every set of users over ``capacity`` has a pair over it.

    Sorted ascending, a set of users is pairwise within the capacity iff
    its two largest are; the heaviest such set whose largest member is
    ``a_k`` is ``a_k`` with every earlier ``a_j`` such that
    ``a_j + a_k <= capacity``. Time is ignored, which can only say
    False where the pairs would do.
    """
    ordered = sorted(a for a in amounts if a > 0)
    for k, largest in enumerate(ordered):
        if largest > capacity:
            break  # alone over it: such a user is never scheduled
        beside = [a for a in ordered[:k] if a + largest <= capacity]
        if sum(beside) + largest > capacity:
            return False
    return True


def minimal_sets(amounts: list[float], capacity: float) -> tuple[int, int]:
    """Minimal over-capacity sets of users: the pairs and the triples.

    Users alone over the capacity (never scheduled) are left out. A set
    of three counts if it exceeds the capacity and none of its pairs
    does. Time is ignored.

    Returns
    -------
    tuple of int
        The number of pairs over ``capacity`` and of such triples.
    """
    fitting = sorted(a for a in amounts if 0 < a <= capacity)
    pairs = triples = 0
    for k, third in enumerate(fitting):
        for j in range(k):
            second = fitting[j]
            if second + third > capacity:
                pairs += 1
                continue
            # fitting[i] <= second: the pair (i, k) is within capacity
            # too, so the triple is minimal iff it exceeds the capacity.
            triples += sum(
                1 for i in range(j) if fitting[i] + second + third > capacity
            )
    return pairs, triples


def pick(problem: Problem, domains: Mapping[str, Domain]) -> Formulation:
    """The formulation to build for ``problem`` (one independent part).

    Parameters
    ----------
    problem
        The part's problem.
    domains
        Its start domains; tasks that cannot be placed are not counted.

    Returns
    -------
    str
        ``disjunctive`` when the part uses no resource, or a binary or
        multiple resource, no consumable, and every multiple resource is
        :func:`pairwise_exact`, or has at most :data:`MAX_USERS` users
        and pairs make at least :data:`MIN_PAIR_SHARE` of the part's
        :func:`minimal_sets`; ``time-indexed`` otherwise.
    """
    kinds = used_kinds(problem, domains)
    if "consumable" in kinds:
        return "time-indexed"
    wide = modelled(problem, domains)
    if wide is None:
        return "time-indexed"
    # The rule reads the part as the model will: the blocks among the
    # users of their resources, at the peak capacities.
    problem, domains = wide
    if not kinds:
        # Precedences and windows only (see the module docstring).
        return "disjunctive"
    exact = True
    pairs = triples = 0
    for name in problem.resources.multiple:
        capacity = problem.resources.peak_capacity(name)
        amounts = [
            task.uses.get(name, 0)
            for task in problem.tasks
            if not domains[task.id].empty
        ]
        if pairwise_exact(amounts, capacity):
            continue
        if sum(1 for a in amounts if a > 0) > MAX_USERS:
            return "time-indexed"
        exact = False
        found = minimal_sets(amounts, capacity)
        pairs += found[0]
        triples += found[1]
    if not exact and pairs < MIN_PAIR_SHARE * (pairs + triples):
        return "time-indexed"
    return "disjunctive"


def switch_nodes(
    problem: Problem, domains: Mapping[str, Domain], max_tasks: int
) -> int | None:
    """Nodes after which a disjunctive run should switch to the
    time-indexed model, or None to let it run.

    The disjunctive model's LP bound on the weighted delays is weak (its
    order rows are big-M rows, and where sets of three or more users
    exceed a capacity only load rows at each start hold them): with a
    multiple resource in use its search can run tens of thousands of
    nodes on a gap the time-indexed model's LP closes in a few hundred
    (see :data:`SWITCH_NODES`), pairwise exact or not (seed 33's
    b15-multiple-5). Parts whose only shared resources are binary keep
    their run: the time-indexed model is far slower there (its LP is
    large and degenerate, see the module docstring). Only parts of up
    to ``max_tasks`` tasks switch (the time-indexed model of a larger
    part may not even fit the limit), or larger ones whose time-indexed
    model has at most :data:`SWITCH_COLUMNS` columns
    (:data:`SWITCH_COLUMNS_BINARY` with a binary resource in use as
    well); the caller asks
    only where :func:`pick` chose the disjunctive model.
    """
    kinds = used_kinds(problem, domains)
    if "multiple" not in kinds:
        return None
    if problem.num_tasks > max_tasks and start_count(domains) > (
        SWITCH_COLUMNS_BINARY if "binary" in kinds else SWITCH_COLUMNS
    ):
        return None
    if "binary" in kinds:
        return SWITCH_NODES
    return SWITCH_NODES_MULTIPLE_ONLY


def used_kinds(
    problem: Problem, domains: Mapping[str, Domain]
) -> set[ResourceKind]:
    """The resource kinds some placeable task of ``problem`` uses."""
    kinds: set[ResourceKind] = set()
    for task in problem.tasks:
        if domains[task.id].empty:
            continue
        for name, amount in task.uses.items():
            kind = problem.resources.kind_of(name)
            if amount and kind is not None:
                kinds.add(kind)
    return kinds
