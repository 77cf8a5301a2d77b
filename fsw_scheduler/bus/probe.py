"""Check from a component's seat which inputs the scheduler accepts from it.

``fsw-scheduler probe --config deploy/monitor.json5`` publishes one
harmless input per kind: a goal whose task list is not a list, a report on
a task that does not exist, a level of a resource that does not exist.
Each would be rejected by the scheduler and counted in its status, and
none changes the plan. After each, the probe asks the scheduler for its
status on the same link: the query arrives behind the input, so if the
counters did not move, the input never reached the scheduler (refused by
the access-control policy, here or at the scheduler). The clock is not
probed: any clock value that got through would move time or be refused as
going back, and a bus clock must not be disturbed.
"""

from __future__ import annotations

import json
import uuid
from dataclasses import dataclass
from typing import TYPE_CHECKING

import msgspec
import zenoh

from ..wire import messages
from ..wire import topics as keys
from .session import wait_matching

if TYPE_CHECKING:
    from collections.abc import Sequence

#: Input kinds the probe tries.
KINDS = ("goal", "report", "level")


@dataclass(frozen=True)
class ProbeResult:
    """What became of one probe input."""

    kind: str
    key: str
    reached: bool
    detail: str


def _status(
    session: zenoh.Session, topics: keys.Topics, timeout: float
) -> messages.Status:
    for reply in session.get(topics.key(keys.STATUS), timeout=timeout):
        if reply.ok is not None:
            return msgspec.json.decode(
                reply.ok.payload.to_bytes(), type=messages.Status
            )
    raise TimeoutError(
        "the scheduler did not answer a status query (is it running, and "
        "may this certificate read scheduler/status?)"
    )


def _counted(kind: str, status: messages.Status) -> int:
    """The counter a probe of ``kind`` moves if it gets through."""
    counters = status.counters
    if kind == "goal":
        return counters.goals_rejected + counters.goals_accepted
    return counters.inputs_rejected + counters.reports


def _input(kind: str, topics: keys.Topics, tag: str) -> tuple[str, dict]:
    name = f"probe-{tag}"
    if kind == "goal":
        return topics.key(keys.GOALS), {
            "goal_id": name,
            "tasks": "not a task list: a probe, to be rejected",
        }
    if kind == "report":
        return topics.activity_report(name), {
            "task": name,
            "state": "completed",
            "at": 0,
        }
    return topics.resource_level(name), {
        "resource": name,
        "level": 0.0,
        "at": 0,
    }


def probe(
    session: zenoh.Session,
    topics: keys.Topics,
    kinds: Sequence[str] = KINDS,
    timeout: float = 10.0,
) -> list[ProbeResult]:
    """Publish one harmless input per kind; say which reached the scheduler.

    Parameters
    ----------
    session
        A session with the component's configuration.
    topics
        The spacecraft's keys.
    kinds
        Among :data:`KINDS`.
    timeout
        Seconds to wait for the scheduler (its subscriber, its answers).

    Raises
    ------
    TimeoutError
        If the scheduler cannot be reached or does not answer.
    """
    results = []
    tag = uuid.uuid4().hex[:8]
    for kind in kinds:
        key, payload = _input(kind, topics, tag)
        try:
            wait_matching(session, key, timeout)
        except TimeoutError:
            results.append(
                ProbeResult(kind, key, False, "no scheduler subscriber seen")
            )
            continue
        before = _counted(kind, _status(session, topics, timeout))
        session.put(
            key,
            json.dumps(payload).encode(),
            encoding=zenoh.Encoding.APPLICATION_JSON,
            congestion_control=zenoh.CongestionControl.BLOCK,
        )
        after = _counted(kind, _status(session, topics, timeout))
        reached = after != before
        detail = (
            "reached the scheduler (and was rejected as a probe)"
            if reached
            else "refused: the scheduler never saw it"
        )
        results.append(ProbeResult(kind, key, reached, detail))
    return results
