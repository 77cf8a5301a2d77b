"""Bus messages (the bus keys): msgspec Structs and their codec.

Evolution rules: a new field always has a default and a field's type
never changes, so older recordings still decode. The inputs that
command (goals, reports, levels, clock) are read strictly
(:mod:`fsw_scheduler.model.strict`: an unknown field is rejected, named,
with the closest known one); the types themselves do not forbid unknown
fields, so that readers of recordings and of the messages the scheduler
publishes accept fields newer than themselves. The files in
``schemas/`` are generated from these types
(:mod:`fsw_scheduler.runtime.schemas`); a test keeps them identical.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec

from ..errors import FieldIssue, InputError
from ..model.change import Removal
from ..model.codec import decode_strict
from ..model.goal import Goal, decode_goal
from ..model.plan import (
    Activity,
    Blocker,
    Moved,
    Objective,
    Plan,
    SolverStats,
    SolveStatus,
)
from ..model.problem import Id, Instant, Problem
from .profiles import LevelCheck, Profiles

#: Largest payload accepted on an input key; bigger ones are rejected
#: before decoding so a huge message cannot stall the event loop.
MAX_PAYLOAD_BYTES = 1 << 20


class Clock(msgspec.Struct, frozen=True):
    """``clock``: bus time in time units."""

    now: Instant


class ActivityReport(msgspec.Struct, frozen=True, omit_defaults=True):
    """``telemetry/activities/<task>``: an execution report.

    A report answers a dispatch: its task must have been dispatched and
    ``at`` must not lie ahead of the scheduler's time. ``dispatch_id`` and
    ``term``, echoed from the dispatch, name which one (a report naming
    another dispatch, or a term the scheduler has not reached, is
    rejected; the ``reports-need-dispatch`` setting makes them required).
    """

    task: Id
    state: Literal["running", "completed", "failed"]
    at: Instant
    detail: str = ""
    dispatch_id: str = ""
    term: Annotated[int, msgspec.Meta(ge=0)] = 0


class ResourceLevel(msgspec.Struct, frozen=True):
    """``telemetry/resources/<name>``: a measured consumable level.

    ``level`` is the level at the start of time unit ``at``.
    """

    resource: Id
    level: float
    at: Instant


class PlanMessage(msgspec.Struct, frozen=True):
    """``scheduler/plan``: the plan being executed (the plan format).

    Attributes
    ----------
    plan_id
        Strictly increasing over a run.
    issued_at
        Time unit at which the plan was adopted.
    horizon_start, horizon_end
        The window ``[start, end)`` the plan covers.
    status, objective, activities, unscheduled
        As in the plan format.
    why
        Why each unscheduled task is out.
    continuing
        Activities that were already running and continue; they are not
        dispatched again.
    deferred
        Accepted tasks whose window opens beyond this horizon; they enter a
        plan (trigger ``horizon``) when the rolling horizon reaches them.
    removed
        Tasks that left the pending list at this replan, with the rule.
    trigger
        What caused the plan: ``initial``, ``goal``, ``failure``,
        ``drift``, ``stale`` (the plan came late), ``horizon`` (the
        rolling horizon reached a deferred task), ``missed`` or
        ``early_completion`` (an activity completed early enough to
        replan, see ``early-completion-gain``).
    goals
        Goal ids adopted by this plan.
    stats
        Solver statistics (timings vary between runs).
    term
        The command term of the node that issued it: a plan is named by
        ``(term, plan_id)``; a receiver ignores a lower term than the
        highest it has seen (0: a node older than terms).
    moved
        The activities planned and not yet dispatched when the replan
        started that this plan starts elsewhere (``task``, ``from``,
        ``to``, and ``why`` where known); empty when nothing moved.
        Present on a node with a commit window or a stability term
        (absent otherwise, so that such a node's plans are those of a
        node without these settings).
    """

    plan_id: int
    issued_at: int
    horizon_start: int
    horizon_end: int
    status: SolveStatus
    objective: Objective | None
    activities: tuple[Activity, ...] = ()
    unscheduled: tuple[str, ...] = ()
    why: tuple[Blocker, ...] = ()
    continuing: tuple[str, ...] = ()
    deferred: tuple[str, ...] = ()
    removed: tuple[Removal, ...] = ()
    trigger: str = ""
    goals: tuple[str, ...] = ()
    stats: SolverStats | None = None
    term: int = 0
    moved: tuple[Moved, ...] | msgspec.UnsetType = msgspec.UNSET


class WhatIfPlan(PlanMessage, frozen=True, kw_only=True):
    """The plan a what-if foresees: a plan message that is not a plan
    yet, so its ``plan_id`` is null."""

    # A narrower type than the plan message's, on purpose: no plan yet.
    plan_id: None = None  # type: ignore[assignment]


class Reason(msgspec.Struct, frozen=True):
    """Why a task is out of a plan, or moved in it: the ``cause`` (as in
    ``why``) and plain words."""

    cause: str
    detail: str


class WhatIfAnswer(msgspec.Struct, frozen=True):
    """The answer of ``scheduler/what-if``: what sending a goal now would do.

    Attributes
    ----------
    verdict
        ``goal_accepted`` or ``goal_rejected``, the verdict the goal would
        get; ``busy`` when a solve in flight did not end within the
        query's timeout (``reasons`` says so; ask again).
    reasons
        Why it would be rejected (``path`` + ``reason``), or busy.
    plan
        The plan it would produce (the shape of ``scheduler/plan``, with
        ``plan_id`` null), or null when rejected.
    moved
        The activities planned now that this plan would start elsewhere.
    unscheduled
        The tasks it would leave out.
    why
        Task id to why it is out (or moved).
    goal_id
        The goal asked about (null when the document had none).
    """

    verdict: Literal["goal_accepted", "goal_rejected", "busy"]
    reasons: tuple[FieldIssue, ...] = ()
    plan: WhatIfPlan | None = None
    moved: tuple[Moved, ...] = ()
    unscheduled: tuple[str, ...] = ()
    why: dict[str, Reason] = {}
    goal_id: str | None = None


class Dispatch(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/dispatch/<task>``: start this activity now.

    An activity is dispatched once per plan change of that activity: a
    replan that keeps it where it was sends nothing. ``dispatch_id``
    (``<task>:<start>-<end>``) names the command; a receiver that already
    acts on that id ignores a repeat, and a new id for the same task
    replaces the earlier command. ``term`` fences: a receiver ignores a
    dispatch whose term is lower than the highest it has seen.
    """

    task: str
    plan_id: int
    start: int
    end: int
    uses: dict[str, float]
    dispatched_at: int = 0
    late: bool = False
    dispatch_id: str = ""
    term: int = 0


class Source(msgspec.Struct, frozen=True, omit_defaults=True):
    """Where an input came from, as far as the scheduler can tell.

    Attributes
    ----------
    zid, eid, sn
        The publishing session's Zenoh id, the publisher's entity id and
        its sequence number, from the sample's source info. Zenoh fills
        source info only when the publisher sets it; without it, ``zid``
        is the session that timestamped the sample, if any. Claimed by the
        sender: not authenticated by itself.
    identity
        The authenticated identity (TLS certificate common name) of the
        sender, when the node can tell it (``|`` between candidates).
    basis
        How ``identity`` was found: ``link``, ``zid`` has a direct link
        authenticated under that name, and the access-control policy lets
        that name publish on the key; ``policy``, the names of the
        connected links the policy lets publish on the key (the sample
        does not say which link it came over); empty, unknown.
    """

    zid: str = ""
    eid: int | None = None
    sn: int | None = None
    identity: str = ""
    basis: str = ""


class InputSource(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/sources``, in the journal only: the source of the input
    on ``key`` recorded right after it."""

    key: str
    source: Source


class SolveSummary(msgspec.Struct, frozen=True, omit_defaults=True):
    """The last solve, as reported in status.

    ``moved`` counts the activities its plan moved (see
    ``PlanMessage.moved``; present when plans report it).
    """

    solve_id: int
    trigger: str
    status: SolveStatus
    objective: Objective | None = None
    wall_s: float = 0.0
    adopted: bool = False
    reason: str = ""
    moved: int | msgspec.UnsetType = msgspec.UNSET


class Counters(msgspec.Struct, frozen=True, omit_defaults=True):
    """Running totals since start.

    ``levels`` counts the resource levels the engine received. The last
    seven are the bus shell's: ``inputs_dropped`` (telemetry that
    found the inbox's byte budget spent; it was never processed),
    ``telemetry_superseded`` and ``clock_superseded`` (samples replaced in
    the inbox by a newer one on the same key before the loop read them:
    the latest value wins),
    ``goals_busy`` (goals refused because too many were waiting; each got
    a ``goal_rejected``), ``queries_dropped``, ``publish_failures`` and
    ``loop_faults`` (inputs whose handling raised; the loop went on).
    ``what_ifs`` counts the what-if queries answered (they change
    nothing else).
    """

    goals_accepted: int = 0
    goals_rejected: int = 0
    solves: int = 0
    solves_failed: int = 0
    dispatches: int = 0
    late_dispatches: int = 0
    reports: int = 0
    inputs_rejected: int = 0
    inputs_dropped: int = 0
    levels: int = 0
    telemetry_superseded: int = 0
    clock_superseded: int = 0
    goals_busy: int = 0
    queries_dropped: int = 0
    publish_failures: int = 0
    loop_faults: int = 0
    what_ifs: int = 0


class Status(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/status``: health, counters and the latest event.

    ``event`` names what this message reports (``started``, ``plan``,
    ``goal_queued``, ``goal_accepted``, ``goal_rejected``,
    ``solve_failed``, ``input_rejected``, ``activity``, ``drift``,
    ``clock_stalled``, ``clock_resumed``, ``heartbeat``,
    ``loop_stopped``, ``alarm``, ``resumed``, ``took_over``); with
    ``goal_id`` and ``errors`` (``path`` + ``reason``) for rejections.
    ``resumed`` and ``took_over`` carry ``from_plan_id`` and ``at`` (the
    plan and time the state was rebuilt at). ``state`` is ``standby`` on a
    node that follows another one; ``active`` then names the commanding
    node, ``node_id`` this one.

    ``activities`` (the lifecycle of every activity) is in heartbeats and
    query answers only; every published status carries ``changed``, the
    entries that changed since the previous published status, so applying
    them in order to the last full map gives the current one.

    ``source`` says where the goal, report or level a verdict is about
    came from (set by the bus node; ``replay --verify`` ignores it).
    ``durable`` is false while the node cannot write its journal (a full
    or failing disk): it commands, but a restart would lose what happened
    since (events ``journal_failed``, ``journal_resumed``).
    ``term`` is the command term of the node (see :class:`Term`). A node
    that stops commanding says ``stood_down`` (``detail`` says why,
    ``active`` names the node it now follows, if any).
    """

    state: Literal["ok", "degraded", "error", "standby"]
    plan_id: int | None
    now: int | None = None
    event: str = ""
    goal_id: str | None = None
    errors: tuple[FieldIssue, ...] = ()
    detail: str = ""
    busy: bool = False
    activities: dict[str, str] = {}
    counters: Counters = Counters()
    last_solve: SolveSummary | None = None
    from_plan_id: int | None = None
    at: int | None = None
    active: str | None = None
    node_id: str | None = None
    changed: dict[str, str] = {}
    why: tuple[Blocker, ...] = ()
    source: Source | None = None
    term: int = 0
    durable: bool = True


class Busy(msgspec.Struct, frozen=True):
    """``scheduler/busy`` (journal only): a goal refused unread.

    The node's inbox already held as many goals (or bytes) as its limits
    allow, so the goal was not decoded; it is reported ``goal_rejected``
    with ``busy: <waiting> goals waiting``. Journaled so that replay
    reproduces the rejection where it happened.
    """

    goal_id: str | None
    waiting: int


class Stalled(msgspec.Struct, frozen=True):
    """``scheduler/stalled`` (journal only): the bus clock stopped.

    No clock message for ``seconds`` of wall-clock time since the last
    one (unit ``last``); the status turns ``degraded`` until one comes.
    """

    seconds: float
    last: int | None = None


class Explanation(msgspec.Struct, frozen=True):
    """``scheduler/explained`` (journal only): why tasks of a plan are out.

    Explanations take extra solves; they run after the plan is published
    (within ``explain-budget``) and reach the loop as this record, which
    replay feeds back where it arrived. The bus sees them as a status
    ``explained`` event with ``why``, and in the plan queryable.
    """

    solve_id: int
    plan_id: int
    why: tuple[Blocker, ...] = ()


class SolveRecord(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/solves``: one record per solve, to re-solve offline.

    ``problem`` is the exact input, ``input_hash`` its SHA-256 (over the
    compact JSON), ``inputs_seen`` how many inputs the scheduler had
    processed when the result came back (used by deterministic replay).
    ``result`` is the solve's whole answer, so that a node resuming from
    its journal rebuilds its state without solving again. ``previous``
    holds the starts a move term priced (with the node's ``stability``
    and ``move-cost`` settings), when there were any.
    """

    solve_id: int
    trigger: str
    input_hash: str
    problem: Problem
    status: SolveStatus
    objective: Objective | None = None
    plan_id: int | None = None
    num_variables: int = 0
    num_constraints: int = 0
    build_s: float = 0.0
    solve_s: float = 0.0
    wall_s: float = 0.0
    inputs_seen: int = 0
    error: str = ""
    result: Plan | None = None
    previous: dict[str, int] = {}


class WhatIfRecord(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/what-if`` (journal only): one what-if and its answer.

    ``document`` is the goal as received, ``inputs_seen`` and ``now`` the
    engine state it was answered from (after that many inputs), ``solves``
    the solves it made (as solve records, results included), so that
    ``replay --verify`` answers it again from the same state and compares.
    """

    document: str
    answer: WhatIfAnswer
    inputs_seen: int = 0
    now: int | None = None
    solves: tuple[SolveRecord, ...] = ()


class SecurityInfo(msgspec.Struct, frozen=True, omit_defaults=True):
    """How the node's bus was protected when it started.

    ``exposed``: an endpoint reaches beyond loopback, or multicast
    scouting is on. ``warnings`` says what an exposed bus lacks (TLS,
    mutual authentication, access control); ``acknowledged``: the operator
    started it so anyway (``run --insecure``).
    """

    exposed: bool = False
    tls: bool = False
    mutual_tls: bool = False
    access_control: bool = False
    acknowledged: bool = False
    warnings: tuple[str, ...] = ()


class Term(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/term``: a node begins to command, in a new term.

    Every takeover, resume and start of command begins a term higher than
    any the node has seen (in its journal, on the bus, in the state it
    adopts). The node journals it (and flushes) before it commands, and
    publishes it so that receivers raise their fence at once: a receiver
    ignores any plan, dispatch or status whose ``term`` is lower than the
    highest it has seen.
    """

    term: int
    node_id: str = ""
    reason: str = ""


class NodeInfo(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/config``: settings a recording needs to be replayed."""

    spacecraft: str
    solver: str
    time_limit_s: float | None
    seed: int
    explain: bool
    clock: str
    explain_budget: float = 2.0
    report_timeout: int | None = None
    drift_absolute: float = 0.0
    drift_relative: float = 0.0
    heartbeat: int = 0
    replan_lead: int = 0
    version: str = ""
    problem: Problem | None = None
    security: SecurityInfo | None = None
    resumed: str = ""
    node_id: str | None = None
    tasks_per_goal: int = 100
    live_tasks: int = 300
    goals_waiting: int = 64
    goals_per_solve: int = 16
    max_clock_step: int | None = None
    explain_after_plan: bool = False
    response_deadline: float | None = None
    goal_ids: int = 1024
    reports_need_dispatch: bool = False
    durable: bool = True


#: Message types of each key (relative to ``fsw/<sc>/``), for schemas.
SCHEMA_TYPES: dict[str, Any] = {
    "clock": Clock,
    "goal": Goal,
    "activity_report": ActivityReport,
    "resource_level": ResourceLevel,
    "plan": PlanMessage,
    "dispatch": Dispatch,
    "status": Status,
    "solve_record": SolveRecord,
    "node_info": NodeInfo,
    "term": Term,
    "input_source": InputSource,
    "problem": Problem,
    "busy": Busy,
    "stalled": Stalled,
    "explanation": Explanation,
    "profiles": Profiles,
    "level_check": LevelCheck,
    "what_if": WhatIfRecord,
}

_encoder = msgspec.json.Encoder()


def encode(message: object) -> bytes:
    """Encode any message as compact JSON (one shared encoder)."""
    return _encoder.encode(message)


def decode_input(kind: str, payload: bytes) -> Any:
    """Decode an input payload of ``kind`` (clock, activity_report, ...).

    Raises
    ------
    InputError
        Oversized payload, malformed JSON, wrong types, missing fields.
    """
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise InputError(
            [
                FieldIssue(
                    "",
                    f"payload of {len(payload)} bytes exceeds the "
                    f"{MAX_PAYLOAD_BYTES}-byte limit",
                )
            ],
            kind,
        )
    if kind == "goal":
        return decode_goal(payload)
    return decode_strict(payload, SCHEMA_TYPES[kind], kind)
