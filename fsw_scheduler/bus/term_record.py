"""What a node says when it begins a term (``scheduler/term``).

The term itself is decided by the node (one above every term it has
verified, :mod:`fsw_scheduler.bus.redundancy`); this module words what
the record says beside it: what is known lost when the node's state is
older than a term in use, and that no one vouches for the state's term
when only the node's own folder does. Pure: no bus.
"""

from __future__ import annotations

import logging

from ..wire import messages

log = logging.getLogger("fsw_scheduler.node")


def term_record(
    term: int,
    node_id: str,
    resumed: str,
    state: tuple[int, int | None, int | None],
    floor: int,
    vouched: int | None,
) -> messages.Term:
    """The record of a term a node begins.

    Parameters
    ----------
    term
        The new term.
    node_id
        Who begins it.
    resumed
        The event the node says first (``took_over``, ``resumed``; empty
        on a first start): the record's reason (``takeover``, ``resume``,
        ``start``).
    state
        The term, plan id and time of the state it begins from.
    floor
        The highest term in use that the node learned elsewhere (its
        folder's term mark, the receivers' fences, the other members).
    vouched
        The highest term someone other than the node's folder vouches for
        (-1: no one answered; None: not asked, as without the election).
    """
    old, plan_id, now = state
    reason = {"took_over": "takeover", "": "start"}.get(resumed, "resume")
    lost = unverified = ""
    if old < floor:
        # The state is older than a term already in use (a restored,
        # moved-aside or empty folder, a lagging copy): say so.
        lost = (
            f"state of term {old} (plan {plan_id}, t={now}) is older than "
            f"term {floor}, already in use: what term {floor} decided after "
            "it is lost; goals without a verdict must be sent again"
        )
    elif vouched is not None and 0 < old > vouched:
        # Resumed on its folder's word alone: a restored copy would reuse
        # a term that receivers fence on.
        unverified = (
            f"term {term} begins from a state of term {old} that no one "
            "else vouches for (no other scheduler; no receiver's fence "
            f"answered scheduler/fences with term {old} or above): if this "
            "folder was restored, moved aside or emptied, a later term may "
            "be in use, and receivers that hold it ignore this node"
        )
    elif vouched is not None and vouched < 0 and old == 0:
        log.warning(
            "term %d: no receiver answered scheduler/fences; a first start, "
            "or an emptied folder (a term may be reused)",
            term,
        )
    return messages.Term(term, node_id, reason, lost, unverified)
