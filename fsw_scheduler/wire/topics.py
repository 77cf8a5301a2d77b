"""Every key expression of the bus, in one place (the bus keys).

Keys are ``fsw/<spacecraft>/<suffix>``; the suffixes below are the public
names. Recording, replay and the scheduler node all derive their keys here.
"""

from __future__ import annotations

import msgspec

PREFIX = "fsw"
DEFAULT_SPACECRAFT = "sat1"

# Inputs
GOALS = "scheduler/goals"
CLOCK = "clock"
TELEMETRY = "telemetry/**"
ACTIVITY_REPORTS = "telemetry/activities"
RESOURCE_LEVELS = "telemetry/resources"

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
#: Recorded only: goals refused unread because the inbox was full.
BUSY = "scheduler/busy"
#: Recorded only: the bus clock stopped ticking (wall-clock detection).
STALLED = "scheduler/stalled"
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
    STALLED: "stalled",
    EXPLAINED: "explanation",
    PROFILES: "profiles",
    LEVELS: "level_check",
    LOG: "log",
    TERM: "term",
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
)
#: Kinds a replay feeds back as inputs, whatever the clock source.
_INPUTS = {
    "goal",
    "busy",
    "explanation",
    "activity_report",
    "resource_level",
    "term",
}


def kind_of(suffix: str) -> str | None:
    """The message kind of a key ``suffix`` (None if it has none)."""
    if suffix in KINDS:
        return KINDS[suffix]
    head, _, name = suffix.rpartition("/")
    return NAMED_KINDS.get(head) if name else None


def input_kind(topics: Topics, key: str, clock: str) -> str | None:
    """The input kind of ``key`` for a node with this clock source.

    Returns ``goal``, ``clock`` (bus clock only), ``tick`` (the journal's
    record of the node's own clock, wall clock only), ``busy`` (the
    journal's record of a goal refused unread), ``activity_report``,
    ``resource_level``, or None for keys that are not scheduler inputs.
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
