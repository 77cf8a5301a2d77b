"""A second chance for list scheduling: perturbed orders (pure).

:func:`~.greedy.greedy_plan` runs each of its rules once. Where none
places the tasks every plan must hold, the same list scheduler in orders
close to the deadline rule's often does: :func:`sampled_plan` tries them
(biased random sampling), for the forced core of
:func:`~fsw_scheduler.solving.forced.forced_start` when the solver has no
plan of it or no time for one. :func:`sampled_better` tries such orders
for a better start plan of a large part, and :func:`sampled_around`
draws them around an incumbent's own order, a local search over orders
for a large part still a whole task short of its bound.
"""

from __future__ import annotations

import random
from typing import TYPE_CHECKING

from .check import check_plan, improves
from .domains import start_domains
from .greedy import order_of, plan_in_order

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

    from ..model.plan import Plan
    from ..model.problem import Problem
    from .domains import Domain

#: Orders :func:`sampled_plan` tries at most.
SAMPLED_ORDERS = 200
#: Spread of the first order's noise, in places of the deadline order;
#: it grows by this much every :data:`SAMPLED_WIDEN` orders. On the
#: forced core of ``tools/fuzz --large`` seed 1192 (23 tasks, two
#: batteries, that no rule places), 100 orders at a fixed spread placed
#: it 87 times at 0.5, 59 at 1, 31 at 4, 15 at 8: the rules' orders are
#: mostly right, and a swap or two of neighbours is what they miss.
SAMPLED_SPREAD = 0.5
SAMPLED_WIDEN = 20
#: Orders :func:`sampled_better` tries at most.
BETTER_ORDERS = 50


def sampled_plan(
    problem: Problem,
    domains: dict[str, Domain] | None = None,
    *,
    stop: Callable[[], bool] | None = None,
    seed: int = 0,
) -> Plan | None:
    """The first valid list schedule among perturbed deadline orders.

    Biased random sampling, the list scheduler's classic second chance
    (Kolisch and Drexl's): the tasks in deadline order (latest start,
    then earliest, then problem order), each moved by Gaussian noise of
    a few places, at most :data:`SAMPLED_ORDERS` times with a spread
    that widens as tries fail. For the tasks every plan must hold when
    no rule of :data:`~.rules.RULES` places them; deterministic (a seeded
    generator, no clock: ``stop`` only ends it early).

    Parameters
    ----------
    problem
        A validated problem.
    domains
        Its :func:`start_domains`, if already known.
    stop
        True when time is up: None is returned.
    seed
        Seed of the noise.

    Returns
    -------
    Plan or None
        Status ``feasible``, objective computed, accepted by the checker;
        None when no order tried gives one.
    """
    if domains is None:
        domains = start_domains(problem)
    for plan in _perturbed(problem, domains, SAMPLED_ORDERS, seed, stop):
        if plan is not None and check_plan(problem, plan).ok:
            return plan
    return None


def sampled_better(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    *,
    stop: Callable[[], bool] | None = None,
    seed: int = 0,
) -> Plan:
    """The best of ``start`` and :data:`BETTER_ORDERS` perturbed deadline
    orders (as :func:`sampled_plan` draws them), each list-scheduled.

    On a day a battery binds, the list scheduler's plan swings with the
    order of a few tasks: ``tools/fuzz --large`` seed 1312's 40-task part
    gave 87,779 by the best rule, 68,783 in the deadline order with ties
    in problem order, 109,510 with them the other way (CP-SAT's optimum
    66,876), and the neighbourhood search did not leave the rule's
    arrangement in 60 s. Deterministic as :func:`sampled_plan`.

    Returns
    -------
    Plan
        ``start``, or a better plan the checker accepts.
    """
    best = start
    for plan in _perturbed(problem, domains, BETTER_ORDERS, seed, stop):
        if plan is not None and improves(problem, plan, best):
            best = plan
    return best


def _perturbed(
    problem: Problem,
    domains: dict[str, Domain],
    orders: int,
    seed: int,
    stop: Callable[[], bool] | None,
) -> Iterator[Plan | None]:
    """List schedules (not checked) of ``orders`` perturbed deadline
    orders, the spread widening every :data:`SAMPLED_WIDEN`; ends early
    when ``stop()``."""
    base = sorted(
        (t.id for t in problem.tasks),
        key=lambda n: (domains[n].latest, domains[n].earliest),
    )
    draw = random.Random(seed)
    for k in range(orders):
        if stop is not None and stop():
            return
        spread = SAMPLED_SPREAD * (1 + k // SAMPLED_WIDEN)
        yield plan_in_order(problem, _noisy(base, draw, spread), domains)


def _noisy(order: list[str], draw: random.Random, spread: float) -> list[str]:
    """``order`` with each task moved by Gaussian noise of ``spread``
    places (one draw per task, in order)."""
    noisy = {n: i + draw.gauss(0.0, spread) for i, n in enumerate(order)}
    return sorted(order, key=noisy.__getitem__)


#: Orders :func:`sampled_around` tries at most.
AROUND_ORDERS = 300
#: Spread of its noise, in places of the incumbent's order. On the large
#: suite's b45-h1440 of seed 241 (45 tasks, three binary resources,
#: power, data rate and a battery), 300 orders from the plan its search
#: ended with (9 units left out) left out 7 with 1 of 4 seeds of the
#: noise at a spread of 1, 2 of 4 at 2 and at 3, and not at 4 (one seed).
AROUND_SPREAD = 2.0


def sampled_around(
    problem: Problem,
    start: Plan,
    domains: dict[str, Domain],
    *,
    orders: int = AROUND_ORDERS,
    stale: int | None = None,
    stop: Callable[[], bool] | None = None,
    seed: int = 0,
) -> Plan:
    """The best list schedule of orders drawn around the incumbent's.

    Biased random sampling as :func:`sampled_plan`'s, centred on the
    order of ``start``'s starts (left-out tasks last, in problem order)
    and re-centred on each better plan: a local search over orders,
    whose every step is a whole list schedule. On a day a battery
    binds, the kept set is a matter of order (which task takes the
    charge first), and the neighbourhood search, which moves a few tasks
    of the same kept set at a time, does not leave an arrangement: the
    large suite's b45-h1440 of seed 241 kept its 9 units left out for 60
    s of search, where CP-SAT leaves out 6; from the incumbent after the
    kept set's growth, 300 orders (3.7 s, 12 ms a schedule) leave out 7.
    Deterministic (a seeded generator, no clock: ``stop`` only ends it
    early). With ``stale``, it ends after that many orders in a row
    that found nothing better.

    Returns
    -------
    Plan
        ``start``, or a better plan the checker accepts.
    """
    best = start
    order = order_of(problem, start)
    draw = random.Random(seed)
    last = 0  # the order that found the incumbent
    for k in range(orders):
        if (stale is not None and k - last >= stale) or (
            stop is not None and stop()
        ):
            break
        plan = plan_in_order(
            problem, _noisy(order, draw, AROUND_SPREAD), domains
        )
        if plan is not None and improves(problem, plan, best):
            best, last = plan, k + 1
            order = order_of(problem, plan)
    return best
