"""What makes a journal open well in Foxglove: derived channels, metadata.

The scheduler node journals its inputs and outputs as they are. This
module derives, from that same stream, what a visualiser needs on top:

* ``scheduler/profiles`` (published on the bus and journaled): the
  predicted consumable levels of each plan
  (:mod:`fsw_scheduler.wire.profiles`);
* ``scheduler/levels`` (journal only): each measured level beside the
  prediction of the plan in force, one channel a Plot panel can draw
  "predicted against measured" from;
* ``scheduler/log`` (journal only): decisions and rejections as
  ``foxglove.Log`` messages (the well-known schema, so Foxglove's Log
  panel shows them): plans, removals, dispatches, accepted and rejected
  goals, rejected inputs, drift, failed solves;
* the session metadata and attachments written at the head of a journal
  (:func:`session_records`).

:class:`Annotator` is a deterministic function of the messages it is
shown, in order, so :func:`fsw_scheduler.journal.replay.verify` derives the
same
channels from a replayed session and compares them with the journal.
No bus, no wall clock: times are passed in.
"""

from __future__ import annotations

import json
import platform
from datetime import datetime, timezone
from importlib import metadata as dist_metadata
from typing import TYPE_CHECKING, Any, NamedTuple

import msgspec

from ..runtime.schemas import json_schemas
from ..wire import topics as keys
from ..wire.messages import (
    ActivityReport,
    Dispatch,
    PlanMessage,
    ResourceLevel,
    SolveRecord,
    Status,
)
from ..wire.profiles import Profiles, level_check, plan_profiles
from ..wire.topics import Topics

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..engine.core import Engine
    from ..model.problem import Problem
    from ..runtime.config import NodeConfig

__all__ = [
    "DERIVED",
    "LOG_SCHEMA",
    "Annotator",
    "Derived",
    "Log",
    "LogTime",
    "engine_problem",
    "session_records",
    "settings_toml",
    "versions",
]

#: Suffixes of the derived channels and whether they go on the bus.
DERIVED = {
    keys.PROFILES: True,
    keys.LEVELS: False,
    keys.LOG: False,
}

# foxglove.LogLevel
UNKNOWN, DEBUG, INFO, WARNING, ERROR, FATAL = range(6)

#: The ``foxglove.Log`` JSON Schema (foxglove/schemas), recorded on
#: ``scheduler/log`` under that exact name so Foxglove recognises it.
LOG_SCHEMA: dict[str, Any] = {
    "title": "foxglove.Log",
    "description": "A log message",
    "$comment": "The foxglove.Log schema of foxglove/schemas",
    "type": "object",
    "properties": {
        "timestamp": {
            "type": "object",
            "title": "time",
            "properties": {
                "sec": {"type": "integer", "minimum": 0},
                "nsec": {
                    "type": "integer",
                    "minimum": 0,
                    "maximum": 999999999,
                },
            },
            "description": "Timestamp of log message",
        },
        "level": {
            "title": "foxglove.LogLevel",
            "description": "Log level",
            "oneOf": [
                {"title": name, "const": value}
                for value, name in enumerate(
                    ("UNKNOWN", "DEBUG", "INFO", "WARNING", "ERROR", "FATAL")
                )
            ],
        },
        "message": {"type": "string", "description": "Log message"},
        "name": {"type": "string", "description": "Process or node name"},
        "file": {"type": "string", "description": "Filename"},
        "line": {
            "type": "integer",
            "minimum": 0,
            "description": "Line number in the file",
        },
    },
    "required": ["timestamp", "level", "message", "name", "file", "line"],
}


class LogTime(msgspec.Struct, frozen=True):
    """``foxglove.Log.timestamp``: seconds and nanoseconds since the epoch."""

    sec: int
    nsec: int


class Log(msgspec.Struct, frozen=True):
    """A ``foxglove.Log`` message.

    ``timestamp`` is the journal log time of the message that caused the
    entry; ``name`` the scheduler (``fsw/<sc>/scheduler``); ``file`` the
    key of that message; ``line`` is always 0.
    """

    timestamp: LogTime
    level: int
    message: str
    name: str
    file: str
    line: int = 0


class Derived(NamedTuple):
    """One derived message: key suffix, JSON payload, whether to publish."""

    suffix: str
    payload: bytes
    publish: bool


_encoder = msgspec.json.Encoder()
#: The kinds the annotator derives from, each with its decoder (built once).
_DECODERS: dict[str, msgspec.json.Decoder[Any]] = {
    "solve_record": msgspec.json.Decoder(SolveRecord),
    "plan": msgspec.json.Decoder(PlanMessage),
    "status": msgspec.json.Decoder(Status),
    "dispatch": msgspec.json.Decoder(Dispatch),
    "resource_level": msgspec.json.Decoder(ResourceLevel),
    "activity_report": msgspec.json.Decoder(ActivityReport),
}
_STATUS_LEVELS = {
    "goal_accepted": INFO,
    "goal_rejected": WARNING,
    "input_rejected": WARNING,
    "drift": WARNING,
    "solve_failed": ERROR,
}


class Annotator:
    """Derive the profile, level and log channels from the node's stream.

    Show it every message the node journals or publishes, in order, with
    :meth:`observe`; it returns what to add after that message.

    Parameters
    ----------
    topics
        The spacecraft's keys.
    current
        Returns the engine's current plan id and problem. A plan adopted
        without a solve (nothing left to schedule) has no solve record to
        take its problem from; this supplies it. The node and the replay
        both pass their engine's.
    """

    def __init__(
        self,
        topics: keys.Topics,
        current: Callable[[], tuple[int | None, Problem | None]] | None = None,
    ) -> None:
        self.topics = topics
        self._current = current
        self.profiles: Profiles | None = None
        self._problems: dict[int, Problem] = {}
        self._name = topics.key("scheduler")

    def observe(
        self, key: str, payload: bytes, log_time_ns: int = 0
    ) -> list[Derived]:
        """The derived messages that follow ``payload`` on ``key``.

        Parameters
        ----------
        key
            Where the message was seen or published.
        payload
            Its JSON bytes.
        log_time_ns
            Its journal log time (stamps the log entries).

        Returns
        -------
        list of Derived
            Possibly empty; undecodable payloads derive nothing (the
            engine reports them itself).
        """
        # The bytes form: a replay (and the node's inputs) have only the
        # bytes, so they are decoded here, once.
        decoder = _DECODERS.get(self.topics.schema_kind(key) or "")
        if decoder is None:
            return []
        try:
            message = decoder.decode(payload)
        except (msgspec.DecodeError, msgspec.ValidationError):
            return []
        return self.observe_message(key, message, log_time_ns)

    def observe_message(
        self, key: str, message: msgspec.Struct, log_time_ns: int = 0
    ) -> list[Derived]:
        """:meth:`observe` for a message already typed (the node's outputs).

        Parameters
        ----------
        key
            Where the message was seen or published.
        message
            A solve record, plan, status, dispatch, resource level or
            activity report; any other message derives nothing.
        log_time_ns
            Its journal log time (stamps the log entries).
        """
        try:
            if isinstance(message, SolveRecord):
                if message.plan_id is not None:
                    self._problems[message.plan_id] = message.problem
                return []
            if isinstance(message, PlanMessage):
                return self._on_plan(key, message, log_time_ns)
            if isinstance(message, Status):
                return self._on_status(key, message, log_time_ns)
            if isinstance(message, Dispatch):
                return self._on_dispatch(key, message, log_time_ns)
            if isinstance(message, ResourceLevel):
                return [self._level(message)]
            if isinstance(message, ActivityReport):
                return self._on_report(key, message, log_time_ns)
        except ValueError:
            return []
        return []

    # -- derivations -------------------------------------------------------

    def _log(
        self, key: str, level: int, text: str, log_time_ns: int
    ) -> Derived:
        sec, nsec = divmod(max(log_time_ns, 0), 1_000_000_000)
        entry = Log(LogTime(sec, nsec), level, text, self._name, key)
        return Derived(keys.LOG, _encoder.encode(entry), DERIVED[keys.LOG])

    def _level(self, level: ResourceLevel) -> Derived:
        check = level_check(self.profiles, level)
        return Derived(
            keys.LEVELS, _encoder.encode(check), DERIVED[keys.LEVELS]
        )

    def _on_plan(
        self, key: str, plan: PlanMessage, log_time_ns: int
    ) -> list[Derived]:
        out = []
        problem = self._problems.pop(plan.plan_id, None)
        if problem is None and self._current is not None:
            plan_id, current = self._current()
            if plan_id == plan.plan_id:
                problem = current
        if problem is not None:
            self.profiles = plan_profiles(problem, plan)
            out.append(
                Derived(
                    keys.PROFILES,
                    _encoder.encode(self.profiles),
                    DERIVED[keys.PROFILES],
                )
            )
        objective = plan.objective
        cost = (
            f"unscheduled cost {objective.unscheduled_cost}, "
            f"delay cost {objective.delay_cost}"
            if objective is not None
            else "no objective"
        )
        lines = [
            f"plan {plan.plan_id} ({plan.trigger or 'initial'}, "
            f"{plan.status.value}, {cost}) over "
            f"[{plan.horizon_start}, {plan.horizon_end}): "
            + ", ".join(
                f"{a.task} [{a.start}, {a.end})" for a in plan.activities
            )
        ]
        scheduled = {a.task for a in plan.activities}
        # A broken pin of the commit window may be scheduled elsewhere.
        lines += [
            f"{'moved' if b.task in scheduled else 'unscheduled'} "
            f"{b.task}: {b.cause} ({b.detail})"
            for b in plan.why
        ]
        lines += [
            f"removed {r.task} ({r.rule})"
            for r in plan.removed
            if r.rule != "finished"
        ]
        out.append(self._log(key, INFO, "\n".join(lines), log_time_ns))
        return out

    def _on_status(
        self, key: str, status: Status, log_time_ns: int
    ) -> list[Derived]:
        level = _STATUS_LEVELS.get(status.event)
        if level is None:
            return []
        text = status.event.replace("_", " ")
        if status.goal_id:
            text += f" {status.goal_id}"
        if status.detail:
            text += f": {status.detail}"
        for issue in status.errors:
            text += f"\n  {issue.path or '(document)'}: {issue.reason}"
        return [self._log(key, level, text, log_time_ns)]

    def _on_dispatch(
        self, key: str, dispatch: Dispatch, log_time_ns: int
    ) -> list[Derived]:
        late = " (late)" if dispatch.late else ""
        text = (
            f"dispatch {dispatch.task} [{dispatch.start}, {dispatch.end}) "
            f"of plan {dispatch.plan_id} at {dispatch.dispatched_at}{late}"
        )
        level = WARNING if dispatch.late else INFO
        return [self._log(key, level, text, log_time_ns)]

    def _on_report(
        self, key: str, report: ActivityReport, log_time_ns: int
    ) -> list[Derived]:
        if report.state != "failed":
            return []
        detail = f": {report.detail}" if report.detail else ""
        return [
            self._log(
                key,
                ERROR,
                f"{report.task} failed at {report.at}{detail}",
                log_time_ns,
            )
        ]


# -- session metadata and attachments ------------------------------------

_DEPENDENCIES = (
    "fsw-scheduler",
    "msgspec",
    "eclipse-zenoh",
    "mcap",
    "pulp",
    "highspy",
    "matplotlib",
)


def versions() -> dict[str, str]:
    """Python's version and those of the installed dependencies."""
    found = {"python": platform.python_version()}
    for name in _DEPENDENCIES:
        try:
            found[name] = dist_metadata.version(name)
        except dist_metadata.PackageNotFoundError:
            continue
    return found


def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    return json.dumps(str(value))


def settings_toml(config: NodeConfig) -> str:
    """The node settings as the TOML file ``--settings`` reads.

    Settings left at None (meaning "the default") are omitted.
    """
    data = msgspec.to_builtins(config)
    lines = [
        f"{key} = {_toml_value(value)}"
        for key, value in data.items()
        if value is not None
    ]
    return "\n".join(lines) + "\n"


def engine_problem(engine: Engine) -> tuple[int | None, Problem | None]:
    """An engine's plan id and the problem its plan solves (for
    :class:`Annotator`)."""
    schedule = engine.schedule
    return engine.plan_id, None if schedule is None else schedule.problem


def session_records(
    config: NodeConfig, problem: Problem, start_ns: int
) -> tuple[list[tuple[str, dict[str, str]]], list[tuple[str, str, bytes]]]:
    """Metadata records and attachments that open a scheduler journal.

    Parameters
    ----------
    config
        The node settings.
    problem
        The initial problem.
    start_ns
        Wall-clock start of the session, ns since the epoch.

    Returns
    -------
    tuple
        Metadata as ``(name, {key: value})``: ``fsw_scheduler.session``
        (spacecraft, start time, clock, solver), ``fsw_scheduler.settings``
        (every node setting) and ``fsw_scheduler.versions`` (Python and the
        package's dependencies); attachments as ``(name, media type,
        bytes)``: ``problem.json`` (the initial problem) and
        ``settings.toml``.
    """
    stamp = datetime.fromtimestamp(start_ns / 1e9, tz=timezone.utc)
    settings = {
        key: "" if value is None else str(value)
        for key, value in msgspec.to_builtins(config).items()
    }
    session = {
        "spacecraft": config.spacecraft,
        "start_time": stamp.isoformat(timespec="milliseconds").replace(
            "+00:00", "Z"
        ),
        "start_ns": str(start_ns),
        "clock": config.clock,
        "solver": config.solver,
        "tasks": str(problem.num_tasks),
        "horizon": str(problem.horizon),
        "keys": keys.Topics(config.spacecraft).everything,
    }
    metadata = [
        ("fsw_scheduler.session", session),
        ("fsw_scheduler.settings", settings),
        ("fsw_scheduler.versions", versions()),
    ]
    attachments = [
        (
            "problem.json",
            "application/json",
            msgspec.json.format(msgspec.json.encode(problem), indent=2),
        ),
        ("settings.toml", "application/toml", settings_toml(config).encode()),
    ]
    return metadata, attachments


def schema_lookup(spacecraft: str) -> Any:
    """Topic -> JSON Schema (or None) for MCAP channels of a spacecraft."""
    topics = Topics(spacecraft)
    # foxglove.Log is the well-known schema, not one generated here.
    schemas = {**json_schemas(), "log": LOG_SCHEMA}

    def lookup(topic: str) -> dict | None:
        kind = topics.schema_kind(topic)
        return schemas.get(kind) if kind else None

    return lookup
