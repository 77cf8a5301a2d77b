"""The flags of ``fsw-scheduler run``, each with the setting it overrides.

One table (:data:`RUN_FLAGS`) declares every flag of ``run`` in the order
``run --help`` shows them and names the node setting
(:class:`~fsw_scheduler.runtime.config.NodeConfig` field) each one
overrides: :func:`add_run_flags` declares them and :func:`run_settings`
maps the parsed flags to settings, so a flag and its setting cannot drift
apart. A flag not given maps to None, which leaves the settings file's
value (or the default) in place.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ...model.limits import MAX_MOVE_COST
from .commands import (
    non_negative_float,
    number_type,
    positive_float,
    positive_int,
)

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable, Mapping

__all__ = [
    "LIMITS",
    "REPLANS",
    "RUN_FLAGS",
    "SAFETY",
    "SECTIONS",
    "RunFlag",
    "add_run_flags",
    "off_if_given",
    "run_settings",
]

#: Group of flags of which at most one may be given.
SAFETY = "safety"

#: Help section of the flags that bound what senders may ask.
LIMITS = "limits"

#: Help section of the flags of predictable replans.
REPLANS = "predictable replans"
#: The title and description of each help section.
SECTIONS = {
    LIMITS: (
        "limits",
        "What a sender gets beyond each limit is in docs/robustness.md; "
        "the same settings exist in the TOML file.",
    ),
    REPLANS: (
        "predictable replans",
        "What a replan may move (docs/rescheduling.md, 'Predictable "
        "replans'); the same settings exist in the TOML file.",
    ),
}


def off_if_given(given: object) -> object:
    """A switch-off flag's setting: False when given, else None (unset)."""
    return False if given else None


@dataclass(frozen=True)
class RunFlag:
    """One flag of ``run``.

    Attributes
    ----------
    name
        The flag, kebab-case (``--time-unit``).
    options
        The keywords of ``argparse``'s ``add_argument`` (help, type,
        choices, metavar, default, action).
    setting
        The node setting it overrides, or None for a flag that is no
        setting (files, journaling, security checks).
    group
        :data:`SAFETY` (mutually exclusive) or :data:`LIMITS` (a help
        section of its own), or None.
    value
        From the parsed flag to the setting's value, when it is not the
        value itself (``--no-standby`` sets ``standby`` to False).
    """

    name: str
    options: Mapping[str, Any] = field(default_factory=dict)
    setting: str | None = None
    group: str | None = None
    value: Callable[[Any], object] | None = None

    @property
    def dest(self) -> str:
        """The attribute of the parsed arguments that holds it."""
        return self.name.removeprefix("--").replace("-", "_")


RUN_FLAGS: tuple[RunFlag, ...] = (
    RunFlag(
        "--problem",
        {
            "metavar": "PROBLEM.json",
            "help": "resources, horizon length and any initial tasks",
        },
    ),
    RunFlag(
        "--settings",
        {
            "metavar": "FILE.toml",
            "help": "the scheduler's settings (strict TOML; an unknown key "
            "exits 2); flags given here override them. The old form "
            "--config FILE.toml still works, with a deprecation message",
        },
    ),
    RunFlag(
        "--spacecraft",
        {"help": "key prefix id (default sat1)"},
        setting="spacecraft",
    ),
    RunFlag(
        "--clock",
        {
            "choices": ("bus", "wall"),
            "help": "time from fsw/<sc>/clock, or the node's own clock",
        },
        setting="clock",
    ),
    RunFlag(
        "--time-unit",
        {
            "type": positive_float,
            "metavar": "S",
            "help": "seconds per time unit with --clock wall",
        },
        setting="time_unit",
    ),
    RunFlag(
        "--horizon",
        {
            "type": positive_int,
            "metavar": "H",
            "help": "horizon length in time units (default: the problem "
            "file's)",
        },
        setting="horizon",
    ),
    RunFlag(
        "--record",
        {
            "metavar": "FILE.mcap",
            "help": "journal every input and output (for replay --verify)",
        },
    ),
    RunFlag(
        "--state",
        {
            "metavar": "DIR",
            "help": "keep the node's state in DIR: a durable journal that a "
            "restarted node resumes from (plan ids, accepted goals, "
            "activity states, a solve in flight); implies journaling",
        },
    ),
    RunFlag(
        "--journal-max-size",
        {
            "type": positive_int,
            "default": 64 * 1024 * 1024,
            "metavar": "BYTES",
            "help": "with --state: start a new journal file, opened by a "
            "state snapshot, past this size (default %(default)s)",
        },
    ),
    RunFlag(
        "--state-max-bytes",
        {
            "type": positive_int,
            "default": 1024 * 1024 * 1024,
            "metavar": "BYTES",
            "help": "with --state: the folder's budget; past it, the oldest "
            "journal files go once a newer one opens with the state "
            "(default %(default)s)",
        },
    ),
    RunFlag(
        "--new-problem",
        {
            "action": "store_true",
            "help": "with --state: when --problem differs from the one the "
            "folder started from, set the folder's state aside (in "
            "DIR/replaced/) and start from the new problem (without it, "
            "such a start is refused)",
        },
    ),
    RunFlag(
        "--keep-runs",
        {
            "type": number_type(int, minimum=2, strict=False),
            "default": 20,
            "metavar": "N",
            "help": "with --state: journal files of the last N starts are "
            "kept (default %(default)s; at least 2)",
        },
    ),
    RunFlag(
        "--node-id",
        {
            "metavar": "ID",
            "help": "this node's name among redundant schedulers (default "
            "<host>-<pid>)",
        },
        setting="node_id",
    ),
    RunFlag(
        "--rank",
        {
            "type": number_type(int, minimum=0, strict=False),
            "metavar": "N",
            "help": "preference among redundant schedulers: the lowest rank "
            "commands when none does yet (default 0)",
        },
        setting="rank",
    ),
    RunFlag(
        "--discovery",
        {
            "type": non_negative_float,
            "metavar": "S",
            "help": "seconds to look for other schedulers before commanding "
            "(default 1)",
        },
        setting="discovery",
    ),
    RunFlag(
        "--no-standby",
        {
            "action": "store_true",
            "help": "command whatever else runs: no election, no hot standby",
        },
        setting="standby",
        value=off_if_given,
    ),
    RunFlag(
        "--solver",
        {"choices": ("cbc", "highs"), "help": "MILP solver"},
        setting="solver",
    ),
    RunFlag(
        "--time-limit",
        {
            "type": positive_float,
            "metavar": "S",
            "help": "seconds per solve (> 0; default 10)",
        },
        setting="time_limit",
    ),
    RunFlag(
        "--insecure",
        {
            "action": "store_true",
            "help": "acknowledge a bus reachable beyond loopback without TLS "
            "or access control (recorded in scheduler/config)",
        },
        group=SAFETY,
    ),
    RunFlag(
        "--require-secure",
        {
            "action": "store_true",
            "help": "refuse to start (exit 2) unless the bus has mutual TLS "
            "on every endpoint and access control, on loopback too (every "
            "process of the computer reaches a loopback bus)",
        },
        group=SAFETY,
    ),
    # Not in the group: it qualifies --require-secure, so it goes with it.
    RunFlag(
        "--trust-loopback",
        {
            "action": "store_true",
            "help": "with --require-secure: accept a loopback-only bus "
            "without TLS or access control (a single trusted computer, a "
            "bench)",
        },
    ),
    RunFlag(
        "--response-deadline",
        {
            "type": float,
            "metavar": "S",
            "help": "seconds from a goal's arrival to its plan; the solve "
            "gets what is left (default 15)",
        },
        setting="response_deadline",
        group=LIMITS,
    ),
    RunFlag(
        "--tasks-per-goal",
        {
            "type": int,
            "metavar": "N",
            "help": "a goal with more tasks is rejected (default 100)",
        },
        setting="tasks_per_goal",
        group=LIMITS,
    ),
    RunFlag(
        "--live-tasks",
        {
            "type": int,
            "metavar": "N",
            "help": "a goal that would make the plan hold more live tasks "
            "is rejected (default 300)",
        },
        setting="live_tasks",
        group=LIMITS,
    ),
    RunFlag(
        "--goals-waiting",
        {
            "type": int,
            "metavar": "N",
            "help": "goals queued behind a solve; more are rejected 'busy' "
            "(default 64)",
        },
        setting="goals_waiting",
        group=LIMITS,
    ),
    RunFlag(
        "--max-clock-step",
        {
            "type": int,
            "metavar": "UNITS",
            "help": "largest forward step of one bus clock message; a "
            "bigger one is rejected (default 100)",
        },
        setting="max_clock_step",
        group=LIMITS,
    ),
    RunFlag(
        "--clock-stall",
        {
            "type": float,
            "metavar": "S",
            "help": "seconds without a bus clock message before the status "
            "turns degraded (default 30)",
        },
        setting="clock_stall",
        group=LIMITS,
    ),
    RunFlag(
        "--commit-window",
        {
            "type": number_type(int, minimum=0, strict=False),
            "metavar": "UNITS",
            "help": "a replan keeps every planned activity starting within "
            "this many units of it where it was (default 0: none)",
        },
        setting="commit_window",
        group=REPLANS,
    ),
    RunFlag(
        "--stability",
        {
            "choices": ("off", "moves", "lexicographic"),
            "help": "off: move anything for the least cost; moves: each "
            "moved activity costs --move-cost; lexicographic: fewest moves "
            "before least delay (default off)",
        },
        setting="stability",
        group=REPLANS,
    ),
    RunFlag(
        "--move-cost",
        {
            "type": number_type(
                int, minimum=1, strict=False, maximum=MAX_MOVE_COST
            ),
            "metavar": "N",
            "help": f"price of one moved activity under --stability moves "
            f"(1 to {MAX_MOVE_COST}, default 5)",
        },
        setting="move_cost",
        group=REPLANS,
    ),
    RunFlag(
        "--early-completion-gain",
        {
            "type": number_type(int, minimum=0, strict=False),
            "metavar": "UNITS",
            "help": "replan when an activity completes at least this many "
            "units before the end of its dispatch (default 0: never)",
        },
        setting="early_completion_gain",
        group=REPLANS,
    ),
    RunFlag(
        "--late-completion",
        {
            "choices": ("off", "push"),
            "help": "off: fly the plan by the clock; push: what depends on "
            "an activity waits for it, and an overrun or a late completion "
            "replans so that it moves later (default off)",
        },
        setting="late_completion",
        group=REPLANS,
    ),
)


def add_run_flags(parser: argparse.ArgumentParser) -> None:
    """Declare every flag of :data:`RUN_FLAGS` on ``run``'s parser.

    A group is made where its first flag comes, so that ``--help`` shows
    the flags and sections in the table's order.
    """
    groups: dict[str, Any] = {}
    for flag in RUN_FLAGS:
        target: Any = parser
        if flag.group == SAFETY:
            if SAFETY not in groups:
                groups[SAFETY] = parser.add_mutually_exclusive_group()
            target = groups[SAFETY]
        elif flag.group is not None:
            if flag.group not in groups:
                groups[flag.group] = parser.add_argument_group(
                    *SECTIONS[flag.group]
                )
            target = groups[flag.group]
        target.add_argument(flag.name, **flag.options)


def run_settings(args: argparse.Namespace) -> dict[str, object]:
    """The node settings the parsed ``run`` flags override.

    Returns
    -------
    dict
        Setting name to value, for every flag of :data:`RUN_FLAGS` that
        has a setting; None for a flag not given, which
        :meth:`~fsw_scheduler.runtime.config.NodeConfig.replace` ignores.
    """
    out: dict[str, object] = {}
    for flag in RUN_FLAGS:
        if flag.setting is None:
            continue
        given = getattr(args, flag.dest)
        out[flag.setting] = given if flag.value is None else flag.value(given)
    return out
