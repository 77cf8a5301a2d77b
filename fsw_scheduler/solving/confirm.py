"""Confirming an optimum CBC claimed after restarting with its cuts.

With a MIP start CBC 2.10 (strategy 1, its default) may fix columns by
reduced cost and search again on a reduced model that keeps the root's
cuts; nothing such a run concludes is a proof
(:func:`~fsw_scheduler.solving.ilp.cbclog.restarted_with_cuts`). The
relaxation's probing rounds (:mod:`.relaxed`) restart so in most runs,
and fast: when such a run calls its answer optimal, :func:`confirmed`
runs the same model again from that answer without the restart, which
proves or betters it.
"""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING

from .ilp.model import Outcome, run_cbc
from .stats import higher

if TYPE_CHECKING:
    from .relaxed import RelaxedModel

#: CBC options added to those of the run that a confirming run repeats:
#: CBC's restart on a reduced model off (its default strategy 1 turns it
#: on). With probing, CBC 2.10 restarts from a model that keeps the
#: probing cuts (:func:`~fsw_scheduler.solving.ilp.cbclog.
#: restarted_with_cuts`, 16 of 24 such runs on the large and orbit
#: suites), which is what makes those runs fast (the 29-task part of the
#: large suite's f30-h1440 of seed 197: 740 nodes and 3.7 s to its
#: optimum, against 16,486 nodes and 8 s without the restart) and is no
#: proof: on ``tools/fuzz`` seed 68044 it proved 79,990 where the optimum
#: is 79,974. Such a run's best solution, when CBC called it optimal,
#: starts a run of the same options without the restart, which proves
#: or betters it. Probing stays on there: the restart, not probing, is
#: unsound, and probing's fixings take most nodes off. Without probing
#: the orbit suite's of45-h2880 of seed 210 (a 42-task part) was not
#: confirmed in its 8,000 nodes (10 s); with it, in 424 nodes and 2.3 s;
#: on five more confirmations of the large suites of seeds 197 and 210
#: probing took 1.5-6.6 times fewer nodes, 1.3 s less to 0.9 s more. A
#: restarted run stopped on its nodes is not run again: its plan is one,
#: and the next round searches on from it (confirming it too took the
#: rounds' time for no proof on the large suite of seed 197).
CONFIRM = ("strategy 0",)

#: The confirming run has this many times the nodes of the run it
#: confirms (a node limit, so the same answer on every machine).
CONFIRM_GROWTH = 4


def confirm_limit(
    began: float, time_limit: float | None, until: float | None
) -> float | None:
    """Seconds a confirming run may take: what is left of ``time_limit``
    from ``began``, or to ``until`` when that is later; None without a
    limit."""
    if time_limit is None:
        return None
    now = time.perf_counter()
    left = time_limit - (now - began)
    return left if until is None else max(left, until - now)


def confirmed(
    built: RelaxedModel,
    outcome: Outcome,
    limit: float | None,
    threads: int,
    seed: int,
    max_nodes: int | None,
) -> Outcome:
    """The answer of a run that restarted with its probing cuts (no
    proof, :data:`CONFIRM`), confirmed: CBC again on the same model, from
    that run's best solution, with the same options but without the
    restart, with :data:`CONFIRM_GROWTH` times its nodes, for ``limit``
    seconds.
    Its answer is sound: optimal, or a plan at least as good with its
    bound. The first run's answer (its plan, the root bound) when no time
    is left for it."""
    if limit is not None and limit <= 0:
        return outcome
    assert outcome.values is not None
    found = built.decode(outcome.status, outcome.values)
    options = built.cbc_options
    # CONFIRM first: CBC reads its options in order, and "strategy 0"
    # turns probing off where cuts are off (probing on before it, then
    # off: 8,000 nodes without a proof where 424 gave one).
    built.cbc_options = (*CONFIRM, *options)
    try:
        again = run_cbc(
            built,
            limit,
            threads,
            seed,
            found.starts(),
            None if max_nodes is None else CONFIRM_GROWTH * max_nodes,
        )
    finally:
        built.cbc_options = options
    if again.values is None:
        return outcome
    return dataclasses.replace(
        again,
        bound=higher(outcome.bound, again.bound),
        solver_status=f"{outcome.solver_status}; again without the restart: "
        f"{again.solver_status}",
    )
