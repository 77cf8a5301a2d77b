"""Problem model: tasks, resources and precedences (problem format).

Every structure is an immutable :class:`msgspec.Struct`. :func:`decode_problem`
turns JSON bytes into a validated :class:`Problem`; anything wrong is raised
as :class:`~fsw_scheduler.errors.InputError` listing every field path and
reason. This module holds the types and that one entry point; the limits
they declare are in :mod:`.limits`, the strict codec in :mod:`.codec` and
the rules in :mod:`.validation` (their names are importable from here too,
as they always were). Pure: no solver, no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

import msgspec

from ..errors import InputError
from . import groups as groups_
from . import profiles, strict
from .codec import MAX_DEPTH_NOTE as MAX_DEPTH_NOTE
from .codec import decode_strict as decode_strict
from .codec import encode as encode
from .codec import read_strict as read_strict
from .limits import ID_CHARS as ID_CHARS
from .limits import MAX_COST as MAX_COST
from .limits import MAX_DELAY_COST as MAX_DELAY_COST
from .limits import MAX_HORIZON as MAX_HORIZON
from .limits import MAX_ID_LENGTH as MAX_ID_LENGTH
from .limits import MAX_TIME as MAX_TIME
from .limits import MIN_COST as MIN_COST
from .limits import MIN_DELAY_COST as MIN_DELAY_COST
from .limits import id_issue as id_issue
from .limits import key_path as key_path
from .limits import shown as shown
from .mission_rules import fill_member_costs
from .validation import duplicate_ids as duplicate_ids
from .validation import time_issues as time_issues
from .validation import validate_problem as validate_problem

if TYPE_CHECKING:
    from collections.abc import Mapping

Preemption = Literal["none", "from_start", "from_interrupt", "delete"]
WindowReading = Literal["task", "start"]
PrecedenceKind = Literal["tight", "lax"]
PrecedenceScope = Literal["both", "at_least_first"]
ResourceKind = Literal["binary", "multiple", "consumable"]

# Static constraints, declared in the types: the decoder checks them and
# the JSON Schemas carry them, so that a schema rejects what the code does.
#: A key-safe id: tasks, goals, resources (see :data:`ID_CHARS`).
Id = Annotated[
    str,
    msgspec.Meta(
        min_length=1,
        max_length=MAX_ID_LENGTH,
        pattern=f"^[{ID_CHARS}]+$",
        description=(
            f"ids are 1 to {MAX_ID_LENGTH} characters of [{ID_CHARS}] "
            "(they are used as bus key chunks)"
        ),
    ),
]
#: A signed number of time units (a precedence's offset).
Time = Annotated[int, msgspec.Meta(ge=-MAX_TIME, le=MAX_TIME)]
#: A time unit of the mission clock: windows, starts, reports, the clock
#: itself; never before time 0.
Instant = Annotated[int, msgspec.Meta(ge=0, le=MAX_TIME)]
#: A number of time units, at least one.
Units = Annotated[int, msgspec.Meta(ge=1, le=MAX_TIME)]
#: A horizon's length: see :data:`~.limits.MAX_HORIZON` for the limit.
Horizon = Annotated[int, msgspec.Meta(ge=1, le=MAX_HORIZON)]
DelayCost = Annotated[int, msgspec.Meta(ge=MIN_DELAY_COST, le=MAX_DELAY_COST)]
ScheduleCost = Annotated[
    int,
    msgspec.Meta(ge=MIN_COST, le=MAX_COST, description="0 = mandatory"),
]
#: A capacity or a level: never negative.
Amount = Annotated[float, msgspec.Meta(ge=0)]
#: A capacity of a step profile: a whole number of units, never negative.
StepCapacity = Annotated[int, msgspec.Meta(ge=0, le=MAX_TIME)]


class Task(msgspec.Struct, frozen=True, omit_defaults=True):
    """One activity to schedule.

    Attributes
    ----------
    id
        Unique task name.
    length
        Duration in time units, > 0.
    delay_cost
        Cost per time unit of starting later than the problem start, 1..5.
    schedule_cost
        Cost of leaving the task out, 0..5; 0 means mandatory.
    preemption
        What happens if a replan finds the task running: ``none`` (keeps
        running), ``from_start`` (rescheduled in full), ``from_interrupt``
        (remaining part rescheduled) or ``delete`` (dropped).
    feasible_interval
        ``[a, b]`` or None for the whole horizon; read per
        :attr:`feasible_interval_applies_to` or the problem-wide default.
    uses
        Amount per time unit of each resource; a negative consumable amount
        is generation.
    feasible_interval_applies_to
        Per-task override of the problem's window reading.
    fixed_start
        Extension: the task must start exactly here and is mandatory. Used
        by replanning for a running task that cannot be preempted.
    """

    id: Id
    length: Units
    delay_cost: DelayCost
    schedule_cost: ScheduleCost
    preemption: Preemption = "none"
    feasible_interval: tuple[Instant, Instant] | None = None
    uses: dict[str, float] = {}
    feasible_interval_applies_to: WindowReading | None = None
    fixed_start: Instant | None = None

    @property
    def mandatory(self) -> bool:
        """True if the task must be scheduled (schedule cost 0 or fixed)."""
        return self.schedule_cost == 0 or self.fixed_start is not None


class Precedence(msgspec.Struct, frozen=True, omit_defaults=True):
    """An ordering between two tasks.

    ``tight``: ``s_after = s_before + l_before + offset``; ``lax``:
    ``s_after >= s_before + l_before + offset``. ``both``: both tasks are
    scheduled or neither; ``at_least_first``: ``after`` needs ``before``.
    """

    before: Id
    after: Id
    kind: PrecedenceKind
    scope: PrecedenceScope = "both"
    offset: Time = 0


class Consumable(msgspec.Struct, frozen=True, omit_defaults=True):
    """A consumable written as an object: initial level and capacity.

    ``{"initial": 8, "max": 10}``. The level at the end of unit ``t`` is
    ``min(max, level at the end of t-1 - net use during t)``: generation
    beyond ``max`` is lost, like charge offered to a full battery. Without
    ``max`` (or written as a plain number) the level has no ceiling.

    With ``external`` (steps ``[[t, r], ...]`` of a net change per unit
    that no task causes, ``r > 0`` charging) the level at the end of unit
    ``t`` is ``min(max, level(t-1) + external(t) - net use during t)``;
    before its first step the rate is 0.

    Attributes
    ----------
    initial
        Level at the start of the problem, ``0 <= initial <= max``.
    max
        The ceiling (capacity), ``>= 0``; None for none.
    external
        Steps of the external rate, ``t`` strictly increasing.
    """

    initial: Amount
    max: Amount | None = None
    external: tuple[tuple[Time, float], ...] = ()


class Binary(msgspec.Struct, frozen=True, omit_defaults=True):
    """A binary resource written as an object: when it is available.

    ``{"available": [[10, 20], [35, 45]]}``: a user may run only in units
    inside one of the half-open windows ``[a, b)``, sorted and disjoint.
    ``{}`` (no ``available``) is always available; ``[]`` never.

    Attributes
    ----------
    available
        The windows, or None for "always".
    """

    available: tuple[tuple[Time, Time], ...] | None = None


class Capacity(msgspec.Struct, frozen=True, omit_defaults=True):
    """A multiple resource whose capacity changes: a step profile.

    ``{"steps": [[0, 60], [30, 40], [45, 60]]}``: capacity ``c_k`` during
    ``[t_k, t_{k+1})``, the last step to the end of the horizon; ``t``
    strictly increasing, the first at or before the problem's start.

    Attributes
    ----------
    steps
        ``[t, capacity]`` pairs, capacities whole numbers ``>= 0``.
    """

    steps: Annotated[
        tuple[tuple[Time, StepCapacity], ...], msgspec.Meta(min_length=1)
    ]


class Resources(msgspec.Struct, frozen=True, omit_defaults=True):
    """The three resource kinds and their capacities / initial levels.

    ``binary`` is a list of names (always available) or an object of
    :class:`Binary` (availability windows). A multiple resource's capacity
    is a number or a :class:`Capacity` step profile. A consumable is its
    initial level (a number: no ceiling) or a :class:`Consumable` (initial
    level, optional capacity and external rate); read them through
    :attr:`initial_levels`, :attr:`ceilings`, :meth:`capacity_profile` and
    :meth:`external_profile` (module :mod:`.profiles`).
    """

    binary: tuple[Id, ...] | dict[str, Binary] = ()
    multiple: dict[str, Amount | Capacity] = {}
    consumable: dict[str, Amount | Consumable] = {}

    def capacity_profile(
        self, name: str, start: int, horizon: int
    ) -> list[float]:
        """Capacity of a binary or multiple resource in every unit.

        Index ``i`` is unit ``start + i``: 1 or 0 for a binary resource
        (inside or outside its windows), the step's capacity for a
        multiple one (KeyError for any other name).
        """
        return profiles.capacity_profile(self, name, start, horizon)

    def external_profile(
        self, name: str, start: int, horizon: int
    ) -> list[float]:
        """A consumable's external net change in every unit (0 without).

        Index ``i`` is unit ``start + i``; ``> 0`` charges.
        """
        return profiles.external_profile(self, name, start, horizon)

    def external_before(
        self, name: str, start: int, horizon: int
    ) -> list[float]:
        """A consumable's net outside change before each unit: index
        ``k`` sums the first ``k`` units of :meth:`external_profile`."""
        return profiles.external_before(self, name, start, horizon)

    def external_charge(self, name: str, start: int, horizon: int) -> float:
        """The sum of a consumable's external charges (rates ``> 0``) over
        ``[start, start + horizon)``, from its steps (no walk of the
        units)."""
        return profiles.external_charge(self, name, start, horizon)

    def peak_capacity(self, name: str) -> float:
        """The largest capacity a binary or multiple resource ever has.

        A bound for the analyses that read one capacity for the whole
        horizon (relaxations stay valid with it); equal to the capacity
        of a resource whose capacity never changes.
        """
        return profiles.peak_capacity(self, name)

    @property
    def changing(self) -> tuple[str, ...]:
        """Names of the resources whose capacity or level changes by
        itself: windows, capacity steps or an external rate."""
        return profiles.changing(self)

    @property
    def initial_levels(self) -> dict[str, float]:
        """Initial level of every consumable, in declaration order."""
        return {
            name: spec.initial if isinstance(spec, Consumable) else spec
            for name, spec in self.consumable.items()
        }

    @property
    def ceilings(self) -> dict[str, float]:
        """The capacity of every consumable that has one."""
        return {
            name: spec.max
            for name, spec in self.consumable.items()
            if isinstance(spec, Consumable) and spec.max is not None
        }

    def initial(self, name: str) -> float:
        """Initial level of consumable ``name`` (KeyError if unknown)."""
        spec = self.consumable[name]
        return spec.initial if isinstance(spec, Consumable) else spec

    def ceiling(self, name: str) -> float | None:
        """Capacity of consumable ``name``; None without one."""
        spec = self.consumable.get(name)
        return spec.max if isinstance(spec, Consumable) else None

    def with_levels(self, levels: Mapping[str, float]) -> Resources:
        """A copy with new initial levels, each capacity kept.

        Levels of consumables not in ``levels`` stay; a level above its
        consumable's capacity is cut to it (the store is full). A
        consumable written as a plain number stays one.
        """
        consumable = dict(self.consumable)
        for name, level in levels.items():
            spec = consumable.get(name)
            if isinstance(spec, Consumable):
                if spec.max is not None:
                    level = min(level, spec.max)
                consumable[name] = msgspec.structs.replace(spec, initial=level)
            else:
                consumable[name] = level
        return msgspec.structs.replace(self, consumable=consumable)

    @property
    def binary_names(self) -> tuple[str, ...]:
        """The binary resources' names, however they are written."""
        return tuple(self.binary)

    def kind_of(self, name: str) -> ResourceKind | None:
        """Return the kind of resource ``name``, or None if unknown."""
        if name in self.binary:
            return "binary"
        if name in self.multiple:
            return "multiple"
        if name in self.consumable:
            return "consumable"
        return None

    @property
    def names(self) -> tuple[str, ...]:
        """All resource names: binary, then multiple, then consumable."""
        return (*self.binary, *self.multiple, *self.consumable)


class Alternative(msgspec.Struct, frozen=True, omit_defaults=True):
    """A group of alternatives: options of tasks, at most one scheduled.

    The tasks of an option are scheduled all together or not at all; at
    most one option of the group is. Leaving the whole group out costs
    its ``schedule_cost`` (0: one option is mandatory); a member task's
    own schedule cost is not used.

    Attributes
    ----------
    id
        The group's name: a key-safe id that no task has.
    schedule_cost
        Cost of leaving every option out, 0..5; 0 means mandatory.
    options
        Each a non-empty list of task ids; a task is in at most one
        option of at most one group.
    """

    id: Id
    schedule_cost: ScheduleCost
    options: Annotated[
        tuple[Annotated[tuple[Id, ...], msgspec.Meta(min_length=1)], ...],
        msgspec.Meta(min_length=1),
    ]


class Problem(msgspec.Struct, frozen=True, omit_defaults=True):
    """A scheduling problem over ``[start, start + horizon)``."""

    horizon: Horizon
    tasks: tuple[Task, ...]
    start: Instant = 0
    feasible_interval_applies_to: WindowReading = "task"
    resources: Resources = Resources()
    precedences: tuple[Precedence, ...] = ()
    alternatives: tuple[Alternative, ...] = ()

    @property
    def groups(self) -> groups_.Groups:
        """The alternatives, indexed (:class:`.groups.Groups`)."""
        return groups_.of(self)

    def required(self, task: Task) -> bool:
        """True if every plan must schedule ``task``
        (:meth:`.groups.Groups.required`)."""
        return self.groups.required(task)

    @property
    def has_mission_model(self) -> bool:
        """True when the problem uses alternatives or resources that change
        over time (the fields of the mission model)."""
        return bool(self.alternatives or self.resources.changing)

    @property
    def end(self) -> int:
        """First time unit after the horizon; every task ends by it."""
        return self.start + self.horizon

    @property
    def num_tasks(self) -> int:
        """Number of tasks."""
        return len(self.tasks)

    def task(self, task_id: str) -> Task:
        """Return the task named ``task_id`` (KeyError if absent)."""
        for task in self.tasks:
            if task.id == task_id:
                return task
        raise KeyError(task_id)

    def window_reading(self, task: Task) -> WindowReading:
        """How ``task``'s feasible interval is read."""
        return task.feasible_interval_applies_to or (
            self.feasible_interval_applies_to
        )

    def start_bounds(self, task: Task) -> tuple[int, int]:
        """Earliest and latest start allowed by horizon, window and pin.

        The range is empty (first > second) when the task cannot be placed.
        """
        earliest, latest = self.start, self.end - task.length
        if task.feasible_interval is not None:
            low, high = task.feasible_interval
            if self.window_reading(task) == "task":
                high -= task.length
            earliest, latest = max(earliest, low), min(latest, high)
        if task.fixed_start is not None:
            earliest = max(earliest, task.fixed_start)
            latest = min(latest, task.fixed_start)
        return earliest, latest

    def replace(self, **changes: object) -> Problem:
        """Return a copy with ``changes`` applied (fields by name)."""
        return msgspec.structs.replace(self, **changes)

    def pinned(self, pins: Mapping[str, int]) -> Problem:
        """Return a copy with each task of ``pins`` fixed to start there
        (a fixed start also makes the task mandatory)."""
        if not pins:
            return self
        return self.replace(
            tasks=tuple(
                task
                if task.id not in pins
                else msgspec.structs.replace(task, fixed_start=pins[task.id])
                for task in self.tasks
            )
        )


_EVERYWHERE = {"", "horizon", "start", "feasible_interval_applies_to"}


def decode_problem(data: bytes | str, *, allow_empty: bool = False) -> Problem:
    """Decode and validate a problem document.

    Parameters
    ----------
    data
        The JSON text of the problem format.
    allow_empty
        Accept a problem with no task (``fsw-scheduler run``: the problem
        gives resources and horizon, goals bring the tasks).

    Returns
    -------
    Problem
        A problem that passed :func:`validate_problem`.

    Raises
    ------
    InputError
        With one :class:`FieldIssue` per problem found.
    """
    problem, issues, bad = read_strict(
        data, Problem, "problem", prepare=fill_member_costs
    )
    # Every rule reads the horizon and the start: with a stand-in for one
    # of them, only the shape is reported.
    if problem is not None and not bad & _EVERYWHERE:
        issues += [
            issue
            for issue in validate_problem(problem, allow_empty=allow_empty)
            if not strict.under(issue.path, bad)
        ]
    if issues or problem is None:
        raise InputError(issues, "problem")
    return problem
