"""Command terms: their range, and which jumps a node believes (pure).

A term is a non-negative 64-bit integer. A node that begins to command
raises it by exactly one over the highest term it has *verified*: its own
state's, and those of the other members of the election (an active token
with its member token, a state a member shared). On an open bus anyone can
write a token, a snapshot or a ``scheduler/term``; a term outside the range
or above the highest verified one by more than :data:`MAX_TERM_JUMP` is
not believed: it is ignored with a warning, never makes a commander stand
down and never raises the term a node commands in. (In the secure profile
only the scheduler role may publish on ``scheduler/**`` at all.)
"""

from __future__ import annotations

#: The highest term: terms are stamped as int64 on every message.
MAX_TERM = 2**63 - 1

#: How far above the highest verified term a term may be and still be
#: believed. Terms rise by one per start, resume, takeover or return to
#: command, so a genuine gap is the number of those a node missed; a
#: million is a restart every 30 s for a year without being watched, and
#: a forger who ratchets by the bound needs nine million million tries
#: to reach :data:`MAX_TERM`.
MAX_TERM_JUMP = 1 << 20


def term_refused(term: object, verified: int) -> str | None:
    """Why ``term`` is not believed by a node that verified ``verified``
    (None: it is believed).

    Parameters
    ----------
    term
        As it came (any JSON value).
    verified
        The highest term this node has verified.

    Examples
    --------
    >>> term_refused(3, 2) is None
    True
    >>> term_refused(2**63, 2)
    'term 9223372036854775808 is outside 0..9223372036854775807'
    """
    if isinstance(term, bool) or not isinstance(term, int):
        return f"term {term!r} is not an integer"
    if not 0 <= term <= MAX_TERM:
        return f"term {term} is outside 0..{MAX_TERM}"
    if term > verified + MAX_TERM_JUMP:
        return (
            f"term {term} jumps more than {MAX_TERM_JUMP} above the "
            f"highest verified term {verified}"
        )
    return None
