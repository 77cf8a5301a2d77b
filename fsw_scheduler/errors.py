"""Exception tree of fsw_scheduler.

Infeasibility and time limits are *statuses* (see
:mod:`fsw_scheduler.model.plan`),
not exceptions. Exceptions are kept for invalid data and environment faults.
"""

from __future__ import annotations

import msgspec


class SchedulerError(Exception):
    """Base class of every error raised by fsw_scheduler."""


class FieldIssue(msgspec.Struct, frozen=True):
    """One problem with an input document.

    Attributes
    ----------
    path
        Where the problem is, as a JSON path relative to the document root,
        e.g. ``tasks[0].length``. Empty for the whole document.
    reason
        What is wrong, in plain words.
    """

    path: str
    reason: str

    def __str__(self) -> str:
        return f"{self.path or '(document)'}: {self.reason}"


class InputError(SchedulerError, ValueError):
    """An input document (problem, plan, goal, event) is invalid.

    Parameters
    ----------
    issues
        Every problem found; each names the field path and the reason.
    what
        What kind of document was being read (for the message).
    """

    def __init__(self, issues: list[FieldIssue], what: str = "input") -> None:
        self.issues = list(issues)
        self.what = what
        lines = "\n".join(f"  {issue}" for issue in self.issues)
        super().__init__(f"invalid {what}:\n{lines}")


class ConfigError(SchedulerError):
    """A configuration file or command-line setting is invalid."""


class SolverError(SchedulerError):
    """The solver backend could not be run (missing binary, crash)."""


class BusError(SchedulerError):
    """The Zenoh bus could not be opened or used."""
