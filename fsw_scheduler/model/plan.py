"""Plans: what a solve returns (the plan format). Pure data."""

from __future__ import annotations

import enum
from typing import Any

import msgspec


class SolveStatus(str, enum.Enum):
    """Outcome of a solve, read from the solver's own solution status.

    ``optimal``: proven optimal. ``feasible``: a limit was hit and the best
    plan found is returned. ``infeasible``: proven that mandatory tasks
    cannot all be placed. ``unknown``: no plan found within the limit.
    ``degraded`` (bus plans only): the mandatory tasks no longer fitted
    together, and this is the best plan without the ones that had to be
    shed; ``why`` names each.
    """

    OPTIMAL = "optimal"
    FEASIBLE = "feasible"
    INFEASIBLE = "infeasible"
    UNKNOWN = "unknown"
    DEGRADED = "degraded"

    @property
    def has_plan(self) -> bool:
        """True when the status comes with a usable plan."""
        return self in (
            SolveStatus.OPTIMAL,
            SolveStatus.FEASIBLE,
            SolveStatus.DEGRADED,
        )


class Activity(msgspec.Struct, frozen=True):
    """A scheduled task: runs over ``[start, end)``."""

    task: str
    start: int
    end: int


class Objective(msgspec.Struct, frozen=True):
    """The lexicographic objective, reported as its two parts.

    ``total = W * unscheduled_cost + delay_cost`` with
    ``W = 1 + sum(delay_cost_i) * horizon``. A replan that prices moves
    (:mod:`fsw_scheduler.model.stability`) also reports ``moves``, the
    previously planned activities it starts elsewhere, and, under
    ``moves``, ``move_cost``, their price; its ``total`` then counts them
    (absent otherwise, so that other plans are as they always were).
    """

    unscheduled_cost: int
    delay_cost: int
    total: int
    moves: int | msgspec.UnsetType = msgspec.UNSET
    move_cost: int | msgspec.UnsetType = msgspec.UNSET


class Blocker(msgspec.Struct, frozen=True):
    """Why a task is not in the plan.

    ``cause`` is one of ``window``, ``precedence``, ``binary``,
    ``multiple``, ``consumable``, ``cost`` (placing it costs more than
    leaving it out), ``combination`` or ``not_analysed``.
    """

    task: str
    cause: str
    detail: str


class Moved(msgspec.Struct, frozen=True, omit_defaults=True):
    """A previously planned activity that a new plan starts elsewhere.

    Attributes
    ----------
    task
        The task id.
    from_, to
        Its start in the plan replaced and in the new plan (``from`` and
        ``to`` on the wire).
    why
        Plain words: why it moved, when that is known.
    """

    task: str
    from_: int = msgspec.field(name="from")
    to: int = msgspec.field(name="to")
    why: str = ""


class SolverStats(msgspec.Struct, frozen=True, omit_defaults=True):
    """How the solve went; figures in seconds.

    ``bound`` is a proven lower bound on the objective ``total`` of every
    plan (None when none is known); ``gap`` is the plan's ``total`` less
    that bound (0 when the plan is proved optimal, None without a bound
    or a plan): how much better a plan could at most be.
    """

    solver: str
    build_s: float = 0.0
    solve_s: float = 0.0
    overhead_s: float = 0.0
    wall_s: float = 0.0
    num_variables: int = 0
    num_constraints: int = 0
    bound: float | None = None
    solver_status: str = ""
    time_limit_s: float | None = None
    gap: float | None = None


class Plan(msgspec.Struct, frozen=True):
    """A solve result: status, objective, activities and what was left out.

    Every task of the problem appears once, in ``activities`` or in
    ``unscheduled``; ``why`` explains each left-out task (and, when the
    status is ``infeasible``, the mandatory tasks that cannot be placed).
    With alternatives, a group member is listed only in ``activities``;
    a group left out is listed in ``unscheduled`` by its id, and
    ``chosen`` gives the option index of every group that has one
    scheduled (``why`` names each option not chosen, cause
    ``alternative``).
    """

    status: SolveStatus
    objective: Objective | None
    activities: tuple[Activity, ...] = ()
    unscheduled: tuple[str, ...] = ()
    why: tuple[Blocker, ...] = ()
    stats: SolverStats | None = None
    # UNSET (not written) for a problem without groups: plans of such
    # problems keep their bytes.
    chosen: dict[str, int] | msgspec.UnsetType = msgspec.UNSET

    @property
    def picks(self) -> dict[str, int]:
        """``chosen``, or an empty dict when the plan has none."""
        return {} if self.chosen is msgspec.UNSET else dict(self.chosen)

    def activity(self, task_id: str) -> Activity | None:
        """The activity of ``task_id``, or None if it is not scheduled."""
        for activity in self.activities:
            if activity.task == task_id:
                return activity
        return None

    def starts(self) -> dict[str, int]:
        """Map task id to start time for scheduled tasks."""
        return {a.task: a.start for a in self.activities}

    def replace(self, **changes: object) -> Plan:
        """Return a copy with ``changes`` applied."""
        return msgspec.structs.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The plan as plain JSON-ready data (the plan format).

        Returns
        -------
        dict
            Built-in types only (``status`` as its string, activities as
            dicts, sequences as lists): ``json.loads(plan.to_json())``.
        """
        # Through JSON rather than msgspec.to_builtins, which keeps tuples:
        # the result must equal json.loads(plan.to_json()).
        data: dict[str, Any] = msgspec.json.decode(msgspec.json.encode(self))
        return data

    def to_json(self, *, indent: int | None = None) -> str:
        """The plan as JSON text (the plan format).

        Parameters
        ----------
        indent
            Spaces per level; ``None`` writes one compact line.
        """
        text = msgspec.json.encode(self)
        if indent is not None:
            text = msgspec.json.format(text, indent=indent)
        return text.decode()


def objective_weight(delay_costs: list[int], horizon: int) -> int:
    """W of the problem format: one unscheduled cost beats any delay."""
    return 1 + sum(delay_costs) * horizon
