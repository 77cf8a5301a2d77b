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
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Literal

import msgspec

from .errors import ConfigError
from .model import id_issue
from .reschedule import Tolerance


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
        Seconds those extra solves may take per plan; the plan waits for
        them, so keep it well under a time unit with the wall clock.
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
        Inputs waiting for the event loop; more are dropped and counted.
    heartbeat
        Units between periodic status messages (0: none).
    replan_lead
        Units between a trigger (goal, failure, drift) and the start of the
        plan it causes, so that a solve may take that long without the new
        plan's first activities being late. Default: 1 with the wall clock,
        0 with the bus clock (which can wait for the scheduler).
    """

    spacecraft: str = "sat1"
    horizon: int | None = None
    solver: Literal["cbc", "highs"] = "cbc"
    time_limit: float | None = 10.0
    seed: int = 0
    threads: int = 1
    explain: bool = True
    explain_budget: float = 2.0
    clock: Literal["bus", "wall"] = "wall"
    time_unit: float = 1.0
    report_timeout: int | None = None
    drift_absolute: float = 0.5
    drift_relative: float = 0.0
    inbox_capacity: int = 1024
    heartbeat: int = 10
    replan_lead: int | None = None

    def __post_init__(self) -> None:
        problems = []
        reason = id_issue(self.spacecraft)
        if reason is not None:
            problems.append(f"spacecraft: the spacecraft id {reason}")
        if self.time_unit <= 0:
            problems.append("time-unit must be > 0")
        if self.explain_budget < 0:
            problems.append("explain-budget must be >= 0")
        if self.time_limit is not None and self.time_limit <= 0:
            problems.append("time-limit must be > 0")
        if self.horizon is not None and self.horizon <= 0:
            problems.append("horizon must be > 0")
        if self.replan_lead is not None and self.replan_lead < 0:
            problems.append("replan-lead must be >= 0")
        if self.inbox_capacity < 1:
            problems.append("inbox-capacity must be >= 1")
        if problems:
            raise ValueError("; ".join(problems))

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
        raise ConfigError(f"{path}: {error}") from None
    try:
        return msgspec.convert(data, NodeConfig)
    except msgspec.ValidationError as error:
        raise ConfigError(f"{path}: {error}") from None
