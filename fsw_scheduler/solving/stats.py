"""What a solve's answer says of itself: its time, its limit, its bound
and its gap."""

from __future__ import annotations

import functools
import time
from typing import TYPE_CHECKING

import msgspec

from ..model.plan import SolveStatus

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..model.plan import Plan


def higher(bound: float | None, other: float | None) -> float | None:
    """The higher of two lower bounds, either of which may be unknown."""
    if bound is None or other is None:
        return other if bound is None else bound
    return max(bound, other)


def method_label(run: Callable[..., Plan], method: str) -> str:
    """The solver's name (``run``'s) and the method, as ``stats.solver``
    says it, e.g. ``cbc-lns``."""
    if isinstance(run, functools.partial):
        return f"{run.keywords.get('solver', 'cbc')}-{method}"
    return method


def stopped_on_nodes(said: str) -> bool:
    """True if a CBC run's status says it stopped on its node limit
    ("Stopped on iterations") and not by time (our interrupt): the same
    answer on every machine, and more nodes might say more."""
    return "on iterations" in said and "interrupted" not in said


def with_gap(plan: Plan) -> Plan:
    """``plan`` with ``stats.gap``: its objective less its proven bound."""
    stats = plan.stats
    if stats is None or stats.bound is None or plan.objective is None:
        return plan
    gap = max(0.0, plan.objective.total - stats.bound)
    if plan.status is SolveStatus.OPTIMAL:
        gap = 0.0
    return plan.replace(stats=msgspec.structs.replace(stats, gap=gap))


def with_call_stats(
    plan: Plan,
    began: float,
    time_limit: float | None,
    *bounds: float | None,
) -> Plan:
    """``plan`` reporting the limit the caller set and the whole call's
    time, its bound dropped where it bounds nothing and raised to the
    highest of ``bounds`` that is not above it.

    Parameters
    ----------
    plan
        The part's answer.
    began
        When the call began (:func:`time.perf_counter`).
    time_limit
        The limit the caller set (None: none).
    bounds
        Lower bounds on every plan at least as good as the start plan,
        so on the optimum: the kept-set relaxation's, the disjunctive
        relaxation's (None where one was not found).
    """
    if plan.stats is None:
        return plan
    bound = plan.stats.bound
    if (
        bound is not None
        and plan.objective is not None
        and bound > plan.objective.total + 0.5
    ):
        # A stopped CBC can report the value of an LP that is not the
        # root's; above a valid plan, it bounds nothing.
        bound = None
    if plan.objective is not None:
        total = plan.objective.total
        for other in bounds:
            if other is not None and other <= total:
                bound = higher(bound, other)
    return plan.replace(
        stats=msgspec.structs.replace(
            plan.stats,
            time_limit_s=time_limit,
            wall_s=time.perf_counter() - began,
            bound=bound,
        )
    )
