"""Every key expression of the bus, in one place (the bus keys).

Keys are ``fsw/<spacecraft>/<suffix>``; the suffixes below are the public
names. Recording, replay and the scheduler node all derive their keys here.
"""

from __future__ import annotations

import re

import msgspec

PREFIX = "fsw"
DEFAULT_SPACECRAFT = "sat1"

# Inputs
GOALS = "scheduler/goals"
CLOCK = "clock"
TELEMETRY = "telemetry/**"
ACTIVITY_REPORTS = "telemetry/activities"
RESOURCE_LEVELS = "telemetry/resources"
#: The last chunk of a forecast key: ``telemetry/resources/<name>/forecast``.
FORECAST = "forecast"

# Outputs
PLAN = "scheduler/plan"
DISPATCH = "scheduler/dispatch"
STATUS = "scheduler/status"
SOLVES = "scheduler/solves"
NODE_INFO = "scheduler/config"
ALIVE = "scheduler/alive"
#: Recorded only (never published): the ticks of the scheduler's own clock.
TICKS = "scheduler/ticks"
#: Recorded only (never published): the source of each input.
SOURCES = "scheduler/sources"
#: The engine's whole state: first message of each journal file (resume),
#: and published by an active node for its hot standby.
SNAPSHOT = "scheduler/snapshot"
#: One liveliness token per node (``scheduler/nodes/<node id>``), so that
#: twins see each other (``scheduler/alive`` tokens merge into one).
NODES = "scheduler/nodes"
#: The liveliness token of the node that commands the spacecraft.
ACTIVE = "scheduler/active"
#: What a commander journals, step by step, for its hot standby: the
#: records after the last shared snapshot (``messages.Changes``).
CHANGES = "scheduler/changes"
#: A standby's word that it holds the commander's state up to a record
#: (``messages.Saved``): what a commander waits for before a goal verdict.
SAVED = "scheduler/saved"
#: Queried only: the state each member holds (its own folder's, the
#: copy it keeps as a standby), ``scheduler/stored/<rank>/<started>/<id>``.
STORED = "scheduler/stored"
#: Queried only: the highest term a receiver has seen (its fence),
#: ``scheduler/fences/<receiver>``.
FENCES = "scheduler/fences"
#: Recorded only: goals refused unread because the inbox was full.
BUSY = "scheduler/busy"
#: Recorded only: telemetry dropped unread because the inbox was full.
DROPPED = "scheduler/dropped"
#: Recorded only: the bus clock stopped ticking (wall-clock detection).
STALLED = "scheduler/stalled"
#: Recorded only: this node's process did not run for a while (a stall
#: under the lease), so a clock jump after it is this node's, not the bus's.
PAUSED = "scheduler/paused"
#: Recorded only: explanations computed after a plan was published.
EXPLAINED = "scheduler/explained"
#: Predicted consumable levels, published with each plan.
PROFILES = "scheduler/profiles"
#: Journal only: measured levels beside the plan's prediction.
LEVELS = "scheduler/levels"
#: Journal only: decisions and rejections as foxglove.Log messages.
LOG = "scheduler/log"
#: A node begins a command term (journaled before it commands, published
#: so that receivers raise their fence): see ``messages.Term``.
TERM = "scheduler/term"
#: A commander that stands down hands over what it commanded (a heal
#: merges facts): an input of the winner, see ``messages.Facts``.
FACTS = "scheduler/facts"

#: A queryable: the payload is a goal, the answer what sending it now
#: would do (``messages.WhatIfAnswer``); journaled with its answer.
WHAT_IF = "scheduler/what-if"

#: Output suffixes, compared by ``replay --verify``.
OUTPUTS = (PLAN, DISPATCH, STATUS)


class Topics(msgspec.Struct, frozen=True):
    """The keys of one spacecraft.

    Parameters
    ----------
    spacecraft
        Spacecraft id, the second key chunk (default ``sat1``).
    """

    spacecraft: str = DEFAULT_SPACECRAFT

    @property
    def root(self) -> str:
        """``fsw/<sc>``."""
        return f"{PREFIX}/{self.spacecraft}"

    def key(self, suffix: str) -> str:
        """``fsw/<sc>/<suffix>``."""
        return f"{self.root}/{suffix}"

    @property
    def everything(self) -> str:
        """``fsw/<sc>/**``: the whole tree (what ``record`` takes)."""
        return self.key("**")

    def dispatch(self, task: str) -> str:
        """The dispatch key of ``task``."""
        return self.key(f"{DISPATCH}/{task}")

    def activity_report(self, task: str) -> str:
        """The execution report key of ``task``."""
        return self.key(f"{ACTIVITY_REPORTS}/{task}")

    def resource_level(self, resource: str) -> str:
        """The level telemetry key of ``resource``."""
        return self.key(f"{RESOURCE_LEVELS}/{resource}")

    def resource_forecast(self, resource: str) -> str:
        """The forecast key of ``resource``."""
        return self.key(f"{RESOURCE_LEVELS}/{resource}/{FORECAST}")

    def suffix(self, key: str) -> str | None:
        """The part of ``key`` after ``fsw/<sc>/``, None if outside."""
        head = self.root + "/"
        return key[len(head) :] if key.startswith(head) else None

    def schema_kind(self, key: str) -> str | None:
        """Which message kind (see ``messages.SCHEMA_TYPES``) ``key`` has."""
        suffix = self.suffix(key)
        return None if suffix is None else kind_of(suffix)


#: The one table from a key suffix to the kind of message it carries
#: (``messages.SCHEMA_TYPES``). ``TICKS`` carries clock messages.
KINDS = {
    CLOCK: "clock",
    GOALS: "goal",
    PLAN: "plan",
    STATUS: "status",
    SOLVES: "solve_record",
    NODE_INFO: "node_info",
    TICKS: "clock",
    SOURCES: "input_source",
    SNAPSHOT: "snapshot",
    BUSY: "busy",
    DROPPED: "dropped",
    STALLED: "stalled",
    PAUSED: "paused",
    EXPLAINED: "explanation",
    PROFILES: "profiles",
    LEVELS: "level_check",
    LOG: "log",
    TERM: "term",
    FACTS: "facts",
    # Every dispatch's journal and view channel (see journal_key).
    DISPATCH: "dispatch",
    WHAT_IF: "what_if",
}
#: Suffixes followed by one name chunk (a task or a resource).
NAMED_KINDS = {
    DISPATCH: "dispatch",
    ACTIVITY_REPORTS: "activity_report",
    RESOURCE_LEVELS: "resource_level",
}
#: What the node subscribes to: (key suffix, kind), from the tables above.
SUBSCRIPTIONS = (
    (GOALS, KINDS[GOALS]),
    (CLOCK, KINDS[CLOCK]),
    (ACTIVITY_REPORTS + "/*", NAMED_KINDS[ACTIVITY_REPORTS]),
    (RESOURCE_LEVELS + "/*", NAMED_KINDS[RESOURCE_LEVELS]),
    (FACTS, KINDS[FACTS]),
    (f"{RESOURCE_LEVELS}/*/{FORECAST}", "resource_forecast"),
)
#: Kinds a replay feeds back as inputs, whatever the clock source.
_INPUTS = {
    "goal",
    "busy",
    "dropped",
    "explanation",
    "activity_report",
    "resource_level",
    "resource_forecast",
    "term",
    "facts",
    "paused",
}


def kind_of(suffix: str) -> str | None:
    """The message kind of a key ``suffix`` (None if it has none)."""
    if suffix in KINDS:
        return KINDS[suffix]
    parts = suffix.split("/")
    if (
        len(parts) == 4
        and "/".join(parts[:2]) == RESOURCE_LEVELS
        and parts[2]
        and parts[3] == FORECAST
    ):
        return "resource_forecast"
    head, _, name = suffix.rpartition("/")
    return NAMED_KINDS.get(head) if name else None


_DISPATCH_KEY = re.compile(rf"^(?P<channel>.+/{DISPATCH})/[^/]+$")


def journal_key(key: str) -> str:
    """The channel a journal and the live view keep ``key``'s messages on.

    Every dispatch goes on one channel, ``<root>/scheduler/dispatch``
    (the task is in the message), so that a long mission does not make a
    channel per task and a view that starts late knows the dispatches
    already made; any other key is its own channel. A journal written
    before (one channel per ``scheduler/dispatch/<task>``) reads the same:
    readers compare keys through this function.
    """
    match = _DISPATCH_KEY.match(key)
    return match.group("channel") if match else key


def bus_key(topic: str, payload: bytes) -> str:
    """The bus key of a message kept on journal channel ``topic``.

    The inverse of :func:`journal_key`: a dispatch goes back to
    ``scheduler/dispatch/<task>``, its task read from the message (the
    topic as it is when the message names none).
    """
    if not topic.endswith("/" + DISPATCH):
        return topic
    try:
        task = msgspec.json.decode(payload, type=_Named).task
    except (msgspec.DecodeError, RecursionError):
        return topic
    return f"{topic}/{task}" if task else topic


class _Named(msgspec.Struct):
    task: str = ""


def input_kind(topics: Topics, key: str, clock: str) -> str | None:
    """The input kind of ``key`` for a node with this clock source.

    Returns ``goal``, ``clock`` (bus clock only), ``tick`` (the journal's
    record of the node's own clock, wall clock only), ``busy`` (the
    journal's record of a goal refused unread), ``dropped`` (of telemetry
    dropped unread), ``activity_report``,
    ``resource_level``, ``resource_forecast``, or None for keys that are
    not scheduler inputs.
    """
    suffix = topics.suffix(key)
    if suffix is None:
        return None
    if suffix == TICKS:
        return "tick" if clock == "wall" else None
    kind = kind_of(suffix)
    if kind in ("clock", "stalled"):
        return kind if clock == "bus" else None
    return kind if kind in _INPUTS else None
