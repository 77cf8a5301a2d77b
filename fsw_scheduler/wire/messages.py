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
from ..model.problem import (
    Id,
    Instant,
    Precedence,
    Problem,
    Resources,
    StepCapacity,
    Task,
    Time,
)
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
    ``at`` must not lie ahead of the scheduler's time by more than the
    ``report-ahead`` setting (such a report is held until the clock
    reaches ``at``, then applied). ``dispatch_id`` and ``term``, echoed
    from the dispatch, name which one (a report naming another dispatch,
    or a term the scheduler has not reached, is rejected; the
    ``reports-need-dispatch`` setting makes them required). ``cancelled``
    answers a cancel (a dispatch with ``action: cancel``): the activity
    was stopped, or never started, at ``at``.
    """

    task: Id
    state: Literal["running", "completed", "failed", "cancelled"]
    at: Instant
    detail: str = ""
    dispatch_id: str = ""
    term: Annotated[int, msgspec.Meta(ge=0)] = 0


class ResourceLevel(msgspec.Struct, frozen=True):
    """``telemetry/resources/<name>``: a measured consumable level.

    ``level`` is the level at the start of time unit ``at``.
    """

    resource: Id
    level: Annotated[
        float,
        msgspec.Meta(ge=0, description="a stored amount is never negative"),
    ]
    at: Instant


class ResourceForecast(msgspec.Struct, frozen=True, omit_defaults=True):
    """``telemetry/resources/<name>/forecast``: a resource's profile ahead.

    From ``at`` on, the resource's profile is the forecast's; before it,
    what the problem had stays. A binary resource's forecast carries
    ``available`` (windows ``[a, b)``), a multiple one's ``steps``
    (``[t, capacity]``), a consumable's ``external`` (``[t, rate]``): the
    fields of the mission model.
    """

    resource: Id
    at: Instant
    available: tuple[tuple[Time, Time], ...] | None = None
    steps: tuple[tuple[Time, StepCapacity], ...] | None = None
    external: tuple[tuple[Time, float], ...] | None = None

    @property
    def fields(self) -> dict[str, tuple[tuple[int, float], ...] | None]:
        """The three profile fields by name (None where absent)."""
        return {
            "available": self.available,
            "steps": self.steps,
            "external": self.external,
        }


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
        ``drift``, ``stale`` (the plan came late, or before what ran was
        known), ``horizon`` (the rolling horizon reached a deferred task),
        ``missed`` (an activity was not commanded in its time),
        ``cancelled`` (a cancel was answered with what ran, or not at
        all), ``merged`` (facts handed over at a heal),
        ``early_completion`` (an activity completed early enough to
        replan, see ``early-completion-gain``), ``overrun`` (an activity
        running past its end held what depends on it beyond its start)
        or ``late_completion`` (a completion after the end of its
        dispatch broke or stretched the plan; see ``late-completion``).
    goals
        Goal ids adopted by this plan.
    stats
        Solver statistics (timings vary between runs).
    term
        The command term of the node that issued it: a plan is named by
        ``(term, plan_id)``; a receiver ignores a lower term than the
        highest it has seen (0: a node older than terms).
    chosen
        The option index of each group of alternatives that has one
        scheduled (only written when the problem has groups).
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
    chosen: dict[str, int] | msgspec.UnsetType = msgspec.UNSET
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
    (``<task>:<start>-<end>``, then ``#<n>`` from the task's second run
    command on: no two commands share one) names the command; a receiver
    that already acts on that id ignores a repeat, and a new id for the
    same task replaces the earlier command. ``term`` fences: a receiver
    ignores a dispatch whose term is lower than the highest it has seen.

    ``action`` is ``run`` (start it) or ``cancel``: stop the dispatch
    ``dispatch_id`` names, or never start it, and answer with a report
    ``cancelled`` echoing its ``dispatch_id`` (``completed`` or ``failed``
    if it had already ended). The scheduler commands a cancelled
    activity again, under a new id, only after that answer.
    ``dispatched_at`` of a cancel is when the cancel was sent.
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
    action: Literal["run", "cancel"] = "run"


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
    ``loop_stopped``, ``alarm``, ``resumed``, ``took_over``,
    ``paused``, ``activity_held``: an activity not commanded at its start
    because something it depends on runs late); with ``goal_id`` and
    ``errors`` (``path`` + ``reason``) for rejections.
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


class Dropped(msgspec.Struct, frozen=True):
    """``scheduler/dropped`` (journal only): telemetry refused unread.

    ``count`` samples of ``kind`` on ``key`` found the node's inbox
    holding ``limit`` bytes already (``inbox-bytes``) and were dropped
    unread; ``size`` is the largest of them, in bytes. The node answers
    them with one ``input_rejected`` (at most one per key and second) and
    journals this record so that replay reproduces the answer where it
    happened. ``key`` is the spacecraft's ``<root>/**`` when too many keys
    had drops waiting for their answer at once.
    """

    key: str
    kind: str
    count: int
    size: int
    limit: int


class Stalled(msgspec.Struct, frozen=True):
    """``scheduler/stalled`` (journal only): the bus clock stopped.

    No clock message for ``seconds`` of wall-clock time since the last
    one (unit ``last``); the status turns ``degraded`` until one comes.
    """

    seconds: float
    last: int | None = None


class Changes(msgspec.Struct, frozen=True):
    """``scheduler/changes``: a commander's journal records, for a standby.

    A hot standby keeps the commander's state from a snapshot plus these
    records, applied in order (:class:`~fsw_scheduler.journal.follow.
    Follower`), instead of a whole snapshot with every step. ``stream``
    names the commander's run (``<node id>:<term>``) and ``seq`` counts
    its messages from 1; a snapshot it shares carries the same two in its
    attachment (``<stream> <seq>``: the state after message ``seq``).
    ``records`` are ``[key, message]`` pairs as journaled. ``confirm``:
    the step's outputs hold a goal verdict, which waits for a standby's
    :class:`Saved` (so a goal accepted is never held by the commander
    alone when both computers are reset).
    """

    stream: str
    seq: int
    term: int
    records: tuple[tuple[str, msgspec.Raw], ...] = ()
    confirm: bool = False


class Saved(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/saved``: a standby holds the commander's state up to
    message ``seq`` of ``stream`` (:class:`Changes`), in its folder and
    synced when ``durable`` (else in memory only: no ``--state``, or its
    disk failed: ``fault`` says how)."""

    stream: str
    seq: int
    node_id: str = ""
    durable: bool = False
    fault: str = ""


class Paused(msgspec.Struct, frozen=True):
    """``scheduler/paused`` (journal only): this node did not run.

    Its process was stopped for ``seconds`` (under the lease: it
    re-verified and still commands) since unit ``last``; what came due
    meanwhile is dispatched late at the next tick instead of missed.
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

    ``lost`` is set when the state this term begins from is older than a
    term already in use (a restored, moved-aside or empty folder, a
    standby's copy that lagged): what that term decided after the state
    is lost, and the node says so (status ``alarm``).

    ``unverified`` is set when the state this term begins from is of a
    term no one else vouches for (no other scheduler, and no receiver's
    fence answered with that term or a higher one): the node resumed on
    its folder's word alone. A folder restored from a copy, moved aside
    or emptied would reuse a term then, and receivers that hold a higher
    one would ignore this node; the node says so (status ``alarm``, state
    unchanged).
    """

    term: int
    node_id: str = ""
    reason: str = ""
    lost: str = ""
    unverified: str = ""


class Fact(msgspec.Struct, frozen=True, omit_defaults=True):
    """One activity a commander commanded, as that commander knows it.

    ``state`` is its lifecycle there (``dispatched``, ``running``,
    ``cancelling``, ``completed``, ``failed``, ``unknown``); ``start``
    and ``end`` the span of the dispatch that stands, when one does, and
    ``number`` its run command's number (its ``dispatch_id`` is
    ``<task>:<start>-<end>``, then ``#<number>`` from 2 on); ``at`` the
    time unit of its last report (or of the state, without one).
    """

    task: Id
    state: Literal[
        "dispatched", "running", "cancelling", "completed", "failed", "unknown"
    ]
    at: Instant = 0
    start: int | None = None
    end: int | None = None
    number: Annotated[int, msgspec.Meta(ge=1)] = 1


class CarriedGoal(msgspec.Struct, frozen=True, omit_defaults=True):
    """A goal a commander accepted of which something was commanded.

    ``digest`` is the ledger's name of its content, so that the goal sent
    again is recognised; ``tasks`` and ``precedences`` its definition as
    that commander holds it.
    """

    goal_id: Id
    digest: str
    at: Instant = 0
    tasks: tuple[Task, ...] = ()
    precedences: tuple[Precedence, ...] = ()


class Facts(msgspec.Struct, frozen=True, omit_defaults=True):
    """``scheduler/facts``: what a commander that stands down commanded.

    When two commanders meet after a partition, the one that stands down
    hands over what it commanded and what its executor reported
    (``facts``, where the winner's shared state says otherwise) and the
    goals it accepted that the winner lacks and of which something was
    commanded (``goals``). The winner journals it as an input and takes
    them as commanded facts: nothing that ran is commanded again, a goal
    partly executed keeps what ran. ``term`` and ``node_id`` name the
    sender.
    """

    term: Annotated[int, msgspec.Meta(ge=0)]
    node_id: str = ""
    facts: tuple[Fact, ...] = ()
    goals: tuple[CarriedGoal, ...] = ()


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
    report_ahead: int = 0
    cancel_timeout: int | None = None


#: Message types of each key (relative to ``fsw/<sc>/``), for schemas.
SCHEMA_TYPES: dict[str, Any] = {
    "clock": Clock,
    "goal": Goal,
    "activity_report": ActivityReport,
    "resource_level": ResourceLevel,
    "resource_forecast": ResourceForecast,
    "plan": PlanMessage,
    "dispatch": Dispatch,
    "status": Status,
    "solve_record": SolveRecord,
    "node_info": NodeInfo,
    "term": Term,
    "facts": Facts,
    "input_source": InputSource,
    "problem": Problem,
    "busy": Busy,
    "dropped": Dropped,
    "stalled": Stalled,
    "paused": Paused,
    "explanation": Explanation,
    "profiles": Profiles,
    "level_check": LevelCheck,
    "what_if": WhatIfRecord,
}

_encoder = msgspec.json.Encoder()


def encode(message: object) -> bytes:
    """Encode any message as compact JSON (one shared encoder)."""
    return _encoder.encode(message)


def decode_input(
    kind: str, payload: bytes, resources: Resources | None = None
) -> Any:
    """Decode an input payload of ``kind`` (clock, activity_report, ...).

    ``resources``, when known, are the running problem's: a goal's uses
    are checked against them in the same pass as its shape.

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
        return decode_goal(payload, resources)
    return decode_strict(payload, SCHEMA_TYPES[kind], kind)
