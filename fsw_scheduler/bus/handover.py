"""What a node hands over when it stops commanding or finds a commander.

Its state to the next term, what it commanded and the goals the
commander lacks (``scheduler/facts``, merged by
:mod:`fsw_scheduler.engine.merge`), and, by name, a goal that cannot be
handed over (``goal_rejected``, "send the goal again").
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import msgspec

from ..engine.merge import facts_of, lost_goals

if TYPE_CHECKING:
    from ..engine.snapshot import EngineSnapshot
    from .members import Member
    from .node import SchedulerNode
    from .redundancy import Redundancy

log = logging.getLogger("fsw_scheduler.redundancy")


def stand_down(
    redundancy: Redundancy,
    node: SchedulerNode,
    winner: Member | None,
    reason: str | None,
) -> EngineSnapshot:
    """Stop commanding: close the node, withdraw the token, say why
    (``reason`` None: the caller says it later)."""
    log.warning("standing down: %s", reason or node.stood_down)
    state = node.engine.snapshot()
    node.close()
    redundancy.withdraw_active()
    redundancy.shared.commanding = False
    redundancy.shared.stored = msgspec.json.encode(state)
    if reason is not None:
        if winner is not None:
            redundancy.ask_snapshot()
        redundancy.publish_standby(winner, "stood_down", reason)
        newer = redundancy.latest_snapshot() if winner is not None else None
        if winner is not None:
            redundancy.hand_over(facts_of(state, newer, redundancy.me.node_id))
        if newer is not None:
            for goal_id in lost_goals(state, newer):
                redundancy.publish_lost_goal(
                    goal_id, state.term, winner, newer.term
                )
    return state


def tell_lost(
    redundancy: Redundancy, own: EngineSnapshot, active: Member
) -> None:
    """A node that starts with a state of its own finds a commander: what
    the commander's state lacks of its last term is handed over, as at a
    heal (a standby back first after both computers were reset may have
    missed the last steps); a goal that cannot be is named, to resend."""
    newer = redundancy.latest_snapshot()
    if newer is None or (newer.term, newer.inputs) == (own.term, own.inputs):
        return
    redundancy.hand_over(facts_of(own, newer, redundancy.me.node_id))
    for goal_id in lost_goals(own, newer):
        redundancy.publish_lost_goal(goal_id, own.term, active, newer.term)
