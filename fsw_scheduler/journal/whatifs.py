"""What-ifs in a journal: the states they were answered from, answered again.

A node journals each what-if (``scheduler/what-if``) with its answer, the
number of inputs its engine had seen when the answer was computed and the
solves it made. Deterministic replay keeps the engine's state at each such
count (:func:`what_if_states`), answers each what-if again from it
(:func:`answer_again`) and compares the answers as :func:`comparable`
gives them: solver statistics and explanations aside, as for plans.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import msgspec

from ..engine.whatif import rejected, what_if
from ..errors import InputError
from ..runtime.inputs import goal_id_of
from ..wire import messages

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ..engine.config import EngineConfig
    from ..engine.events import StartSolve
    from ..engine.snapshot import EngineSnapshot
    from ..model.plan import Plan
    from ..wire import topics as keys
    from .writer import RecordedMessage

__all__ = [
    "WHAT_IF_EXCLUDED",
    "answer_again",
    "comparable",
    "what_if_states",
]

#: Fields of a what-if answer left out of the comparison: solver timings,
#: and explanations (cut by a time budget, like those of any plan).
WHAT_IF_EXCLUDED = ("plan.stats", "plan.why", "why")


def what_if_states(
    recorded: Sequence[RecordedMessage], topics: keys.Topics
) -> set[int]:
    """The engine states (by inputs seen) the journal's what-ifs were
    answered from."""
    found = set()
    for message in recorded:
        if topics.schema_kind(message.topic) == "what_if":
            try:
                record = msgspec.json.decode(
                    message.payload, type=messages.WhatIfRecord
                )
            except (msgspec.DecodeError, msgspec.ValidationError):
                continue
            found.add(record.inputs_seen)
    return found


def answer_again(
    record: messages.WhatIfRecord,
    states: dict[int, EngineSnapshot],
    config: EngineConfig,
    solve: Callable[[StartSolve], Plan],
) -> messages.WhatIfAnswer | str:
    """The answer ``record``'s what-if gets again, or why it cannot be
    recomputed (a ``busy`` answer depended on timing; a state before the
    journal's start is not in it).

    Parameters
    ----------
    record
        The journaled what-if.
    states
        Engine snapshots by inputs seen (:func:`what_if_states`).
    config
        The engine's settings.
    solve
        Runs the what-if's solves as replay runs solves.
    """
    if record.answer.verdict == "busy":
        return (
            f"what-if on {record.answer.goal_id}: answered busy (a solve "
            "was in flight), not recomputed"
        )
    payload = record.document.encode()
    try:
        goal = messages.decode_input("goal", payload)
    except InputError as error:
        return rejected(goal_id_of(payload), error.issues)
    state = states.get(record.inputs_seen)
    if state is None:
        return (
            f"what-if on {goal.goal_id}: its state (after "
            f"{record.inputs_seen} inputs) is not in this journal"
        )
    return what_if(state, config, goal, solve).answer


def comparable(answer: messages.WhatIfAnswer) -> Any:
    """``answer`` as plain data, without :data:`WHAT_IF_EXCLUDED`."""
    data = msgspec.to_builtins(answer)
    for dotted in WHAT_IF_EXCLUDED:
        node = data
        *parents, leaf = dotted.split(".")
        for part in parents:
            node = node.get(part) if isinstance(node, dict) else None
        if isinstance(node, dict):
            node.pop(leaf, None)
    return data
