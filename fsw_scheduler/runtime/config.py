"""Scheduler node settings: a strict TOML file plus command-line overrides.

Zenoh's own settings stay in Zenoh's JSON5 and its standard flags (see
:mod:`fsw_scheduler.bus.session`); this file only holds what the scheduler
itself needs. Unknown keys are an error here (unlike bus messages) so a
typo in a configuration file is caught at start-up.

Example ``scheduler.toml``::

    spacecraft = "sat1"
    solver = "cbc"          # or "highs"
    time-limit = 10.0       # seconds per solve
    clock = "wall"          # or "bus": time from fsw/<sc>/clock
    time-unit = 1.0         # seconds per time unit with the wall clock
    report-timeout = 5      # units after a dispatch without a report
    drift-absolute = 0.5    # level departure that triggers a replan
    replan-lead = 1         # units a solve may take before its plan starts
    commit-window = 5       # a replan keeps what starts within 5 units
    stability = "moves"     # or "off", "lexicographic"
    move-cost = 5           # the price of one moved activity ("moves")
    early-completion-gain = 2  # replan when a report frees >= 2 units
    late-completion = "push"   # what depends on a late activity waits
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Annotated, Literal

import msgspec

from ..errors import ConfigError, FieldIssue
from ..model.limits import MoveCost, Span, id_issue
from ..model.problem import Horizon, Id
from ..model.stability import Mode
from ..model.strict import shape_issues
from ..replan.triggers import Tolerance

#: A count that may be zero (units, ranks).
Count = Annotated[int, msgspec.Meta(ge=0)]
#: A count or a limit of at least one.
AtLeastOne = Annotated[int, msgspec.Meta(ge=1)]
#: A duration in seconds, more than zero.
Seconds = Annotated[float, msgspec.Meta(gt=0)]
#: A budget or a tolerance that may be zero.
NonNegative = Annotated[float, msgspec.Meta(ge=0)]


#: How a replan weighs moving what was already planned.
Stability = Mode
#: What a late activity does to what depends on it.
LateCompletion = Literal["off", "push"]


class NodeConfig(
    msgspec.Struct, frozen=True, forbid_unknown_fields=True, rename="kebab"
):
    """Settings of ``fsw-scheduler run``.

    Attributes
    ----------
    spacecraft
        Second key chunk: keys are ``fsw/<spacecraft>/...``; a key-safe id
        (``[A-Za-z0-9_.-]``, at most 64 characters).
    horizon
        Horizon length H in time units; default: the problem file's.
    solver, time_limit, seed, threads
        Passed to every solve; ``threads = 1`` keeps plans reproducible.
    explain
        Say why tasks are left out (extra solves after each plan).
    explain_budget
        Seconds those extra solves may take per plan. They run after the
        plan is published (``explain_after_plan``), on their own thread,
        so they never delay it; the status then reports ``explained``.
        When a solve gives no plan, they run before the rejection (it
        names the blockers), within what is left of the response
        deadline.
    explain_after_plan
        False: explanations run inside the solve, before the plan is
        published (the behaviour of older recordings).
    response_deadline
        Seconds from a goal's arrival to its verdict and plan: decoding,
        merging, the start plan, the model and the solver all come out of
        it (the solve's limit is cut to what is left). None: only
        ``time_limit`` bounds the solve.
    clock
        ``bus`` (time from ``fsw/<sc>/clock``) or ``wall`` (the node's
        monotonic clock, ``time_unit`` seconds per unit).
    time_unit
        Seconds per time unit with the wall clock.
    report_timeout
        Units after a dispatch with no execution report before the activity
        counts as failed; None waits forever.
    drift_absolute, drift_relative
        A measured level departs from the prediction when
        ``|measured - predicted| > absolute + relative * |predicted|``.
    inbox_capacity
        Goals waiting to be decoded by the event loop; a goal beyond it
        gets ``goal_rejected`` with ``busy: N goals waiting``.
    inbox_bytes
        Payload bytes waiting for the loop (goals and telemetry). A goal
        beyond it is rejected as busy; a telemetry sample beyond it is
        dropped unread, counted (``inputs_dropped``) and answered
        ``input_rejected`` ("dropped: N samples unread", at most once per
        key and second).
        Telemetry and clock samples never queue up: the latest per key
        replaces the one waiting (``telemetry_superseded``).
    tasks_per_goal, live_tasks
        A goal with more tasks, or one that would make the plan hold more
        live tasks (planned, running or deferred), is rejected with the
        reason.
    goals_waiting
        Decoded goals queued behind a solve (each gets ``goal_queued``);
        one more is rejected ``busy: N goals waiting``.
    goals_per_solve
        Goals merged into one solve; the others wait for the next one.
    max_clock_step
        Largest forward step of one bus clock message, in units; a bigger
        one is rejected (``input_rejected``, path ``now``) and time stays.
    clock_stall
        Seconds without a bus clock message after which the status turns
        ``degraded`` (event ``clock_stalled``) until the next one; None
        never.
    heartbeat
        Units between periodic status messages (0: none).
    replan_lead
        Units between a trigger (goal, failure, drift) and the start of the
        plan it causes, so that a solve may take that long without the new
        plan's first activities being late. Default: 1 with the wall clock,
        0 with the bus clock (which can wait for the scheduler).
    node_id
        This node's name among redundant schedulers of the spacecraft
        (key-safe); default: ``<host>-<pid>``.
    rank
        Preference among redundant schedulers: the lowest rank commands
        when none does yet (ties: the earliest start, then the id).
    standby
        Take part in the one-commander protocol (hot standby); off for a
        node that must command whatever else is on the bus.
    discovery
        Seconds a starting node looks for other schedulers before it
        decides to command or to stand by.
    goal_ids
        Accepted goal ids the goal ledger remembers (a re-sent goal among
        them is answered again, never executed again).
    reports_need_dispatch
        Reject execution reports that do not name their ``dispatch_id``.
    report_ahead
        Units an execution report's ``at`` may lie ahead of the node's
        clock (the executor saw a clock message the node has not processed
        yet): held, at most 64, until the clock reaches it, then applied.
        Further ahead: rejected. At least one clock step.
    cancel_timeout
        Units a cancel (a dispatch with ``action: cancel``) waits for its
        answer before the activity turns ``unknown``: taken as having run
        where commanded, never commanded again.
    commit_window
        Units from a replan's ``now``: every planned (not yet dispatched)
        activity that starts in ``[now, now + commit_window)`` keeps its
        start, unless keeping them leaves no plan (then the degraded path
        releases them, and says which it moved). 0: no window.
    stability
        ``off``: a replan may move any planned activity for the least
        cost (the paper). ``moves``: each previously planned activity
        whose start changes costs ``move_cost``, added to the delay part.
        ``lexicographic``: compare plans by unscheduled cost, then the
        number of moved activities, then delay.
    move_cost
        The price of one moved activity under ``stability = "moves"``.
    early_completion_gain
        A ``completed`` report at least this many units before the end of
        its dispatch replans at once (trigger ``early_completion``), so
        that what waits for its resources or follows it may start
        earlier; a smaller gain replans nothing. 0: never.
    late_completion
        ``off``: the plan is flown by the clock, as in the paper.
        ``push``: an activity is not commanded while something it
        depends on runs past its end (a predecessor, or a holder of its
        binary or multiple resources); a held activity whose start passes
        replans (trigger ``overrun``) and a completion after the end of
        its dispatch replans (``late_completion``) when it breaks or
        stretched the plan, so that what depends on it moves later.
    """

    spacecraft: Id = "sat1"
    horizon: Horizon | None = None
    solver: Literal["cbc", "highs"] = "cbc"
    time_limit: Seconds | None = 10.0
    seed: int = 0
    threads: AtLeastOne = 1
    explain: bool = True
    explain_budget: NonNegative = 2.0
    clock: Literal["bus", "wall"] = "wall"
    time_unit: Seconds = 1.0
    report_timeout: AtLeastOne | None = None
    drift_absolute: NonNegative = 0.5
    drift_relative: NonNegative = 0.0
    inbox_capacity: AtLeastOne = 256
    inbox_bytes: Annotated[
        int,
        msgspec.Meta(ge=1 << 20, description="at least one payload (1 MiB)"),
    ] = 64 << 20
    tasks_per_goal: AtLeastOne = 100
    live_tasks: AtLeastOne = 300
    goals_waiting: AtLeastOne = 64
    goals_per_solve: AtLeastOne = 16
    max_clock_step: AtLeastOne | None = 100
    clock_stall: Seconds | None = 30.0
    response_deadline: Seconds | None = 15.0
    explain_after_plan: bool = True
    heartbeat: Count = 10
    replan_lead: Count | None = None
    node_id: Id | None = None
    rank: Count = 0
    standby: bool = True
    discovery: NonNegative = 1.0
    goal_ids: AtLeastOne = 1024
    reports_need_dispatch: bool = False
    report_ahead: Count = 1
    cancel_timeout: AtLeastOne | None = 3
    commit_window: Span = 0
    stability: Stability = "off"
    move_cost: MoveCost = 5
    early_completion_gain: Span = 0
    late_completion: LateCompletion = "off"

    def __post_init__(self) -> None:
        # The ranges are declared once, in the field types (Meta): the
        # file's decoder reads them there, and so does this check of a
        # value built in code or changed by a command-line flag.
        issues = [
            _worded(issue, self)
            for issue in shape_issues(msgspec.to_builtins(self), NodeConfig)
        ]
        if issues:
            raise SettingsError(issues)

    @property
    def lead(self) -> int:
        """The replan lead in units, with its clock-dependent default."""
        if self.replan_lead is not None:
            return self.replan_lead
        return 1 if self.clock == "wall" else 0

    @property
    def tolerance(self) -> Tolerance:
        """The drift tolerance as the rescheduling core takes it."""
        return Tolerance(
            absolute=self.drift_absolute, relative=self.drift_relative
        )

    def replace(self, **changes: object) -> NodeConfig:
        """A copy with ``changes`` (None values are ignored)."""
        kept = {k: v for k, v in changes.items() if v is not None}
        return msgspec.structs.replace(self, **kept)


_AT_LINE = re.compile(r"\(at line (\d+), column \d+\)")
_KEY = re.compile(r"\s*([A-Za-z0-9_.\"'-]+?)\s*=")


class SettingsError(ValueError):
    """Settings out of their declared ranges, every one named.

    A ``ValueError`` (msgspec reports it as a validation error of the
    file); ``issues`` holds them one by one, for a caller that names the
    flags.
    """

    def __init__(self, issues: list[FieldIssue]) -> None:
        self.issues = issues
        super().__init__("; ".join(str(issue) for issue in issues))


def _worded(issue: FieldIssue, config: NodeConfig) -> FieldIssue:
    """An id's issue in the words every id is refused with."""
    name = {"spacecraft": "spacecraft", "node-id": "node"}.get(issue.path)
    value = getattr(config, issue.path.replace("-", "_"), None)
    if name is None or not isinstance(value, str):
        return issue
    reason = id_issue(value)
    return FieldIssue(issue.path, f"the {name} id {reason or issue.reason}")


def _toml_error(path: str | Path, error: tomllib.TOMLDecodeError) -> str:
    """``error`` in words, naming the key TOML refuses to set twice."""
    text = str(error)
    match = _AT_LINE.search(text)
    if match is None or not text.startswith("Cannot overwrite"):
        return text
    lines = Path(path).read_text().splitlines()
    number = int(match.group(1))
    key = _KEY.match(lines[number - 1]) if number <= len(lines) else None
    if key is None:
        return text
    return (
        f"{key.group(1)} is set twice (line {number} sets it again); "
        "a key is set once"
    )


def load_config(path: str | Path | None) -> NodeConfig:
    """Read a TOML settings file (None: defaults).

    Raises
    ------
    ConfigError
        Unreadable file, bad TOML, unknown key or bad value; the message
        names the key.
    """
    if path is None:
        return NodeConfig()
    try:
        data = tomllib.loads(Path(path).read_text())
    except OSError as error:
        raise ConfigError(f"cannot read {path}: {error.strerror}") from None
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{path}: {_toml_error(path, error)}") from None
    issues = shape_issues(data, NodeConfig)
    if any("_" in i.path and "unknown field" in i.reason for i in issues):
        issues.append(
            FieldIssue(
                "",
                "settings keys are kebab-case: report-timeout, "
                "not report_timeout",
            )
        )
    if issues:
        lines = "\n".join(f"  {issue}" for issue in issues)
        raise ConfigError(f"{path}: invalid settings:\n{lines}")
    try:
        return msgspec.convert(data, NodeConfig)
    except msgspec.ValidationError as error:  # a rule of __post_init__
        raise ConfigError(f"{path}: {error}") from None
