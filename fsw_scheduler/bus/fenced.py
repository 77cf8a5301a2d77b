"""A commander asks the receivers' fences now and then: one that holds a
higher term than the commander's ignores its commands.

(It also says when it meets another commander in its own term:
:func:`tie_alarm`.)

A receiver raises its fence to the highest term it sees on any plan,
dispatch, status or ``scheduler/term``. If that is above the commander's
own term, every command is dropped there while the commander sees
nothing wrong: a commander on the other side of a partition that the
receiver sees and this node does not, or a term written by anyone on an
open bus (the secure profile lets only schedulers write there). The
commander cannot tell which, and taking a term above it could make two
commanders outbid each other; it says so instead, as status ``alarm``
(state ``degraded``), every :data:`FENCE_CHECK_S` while it lasts.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from .standby import fence_terms

if TYPE_CHECKING:
    import zenoh

    from ..wire import topics
    from .members import Member
    from .redundancy import Redundancy

#: Seconds between two questions to the receivers' fences while commanding.
FENCE_CHECK_S = 5.0
#: How long one question waits for the fences' answers.
FENCE_ASK_S = 0.5


class FenceWatch:
    """When due, ask ``scheduler/fences/**``; name a fence above a term.

    Parameters
    ----------
    session, keys
        Where the commander asks: its Zenoh session and key expressions.
    every_s
        Seconds between two questions.
    """

    def __init__(
        self,
        session: zenoh.Session,
        keys: topics.Topics,
        every_s: float = FENCE_CHECK_S,
    ) -> None:
        self.session = session
        self.keys = keys
        self.every_s = every_s
        self._due = time.monotonic() + every_s
        #: The alarm of the last answer (None: no fence above the term).
        self.standing: str | None = None

    def check(self, term: int) -> str | None:
        """The alarm to say about the fences (asked when due) for a node
        commanding in ``term``; None when no fence is above it or it is
        not time to ask (:attr:`standing` keeps the last answer's, and
        so does a question no fence answers)."""
        now = time.monotonic()
        if now < self._due:
            return None
        self._due = now + self.every_s
        self.standing = self._ask(term)
        return self.standing

    def _ask(self, term: int) -> str | None:
        answers = fence_terms(self.session, self.keys, FENCE_ASK_S)
        if not answers:
            # No fence answered in time (a loaded machine, receivers
            # restarting): no sign that a fence above fell, so the last
            # answer stands. Read as "none above", a status asked next
            # said ``ok`` while the receiver still dropped every command.
            return self.standing
        above = [(where, seen) for where, seen in answers if seen > term]
        if not above:
            return None
        where, seen = max(above, key=lambda answer: answer[1])
        return (
            f"receiver {where.rsplit('/', 1)[-1]} fences term {seen}, above "
            f"this node's term {term}: it ignores this node's commands (a "
            "commander this node cannot see, or a term forged on an open "
            "bus)"
        )


def tie_alarm(
    redundancy: Redundancy, term: int, said: set[Member]
) -> str | None:
    """The alarm of a commander that meets another one in its own term
    (each began it on its side of a split: the plans of that term are not
    told apart by ``(term, plan_id)``), once per other node; None: none."""
    members, actives = redundancy.view()
    others = sorted(
        m
        for m, t in actives.items()
        if t == term and m != redundancy.me and m in members and m not in said
    )
    if not others:
        return None
    said.update(others)
    names = ", ".join(m.node_id for m in others)
    return (
        f"{names} also commanded in term {term} (each side of a split began "
        f"it): plans of term {term} from both are not told apart by "
        "(term, plan_id); this node's stand from now on (it outranks "
        f"{names}, which stands down)"
    )
