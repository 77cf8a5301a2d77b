"""Problem model: tasks, resources and precedences (problem format).

Every structure is an immutable :class:`msgspec.Struct`. :func:`decode_problem`
turns JSON bytes into a validated :class:`Problem`; anything wrong is raised
as :class:`~fsw_scheduler.errors.InputError` listing every field path and
reason. This module is pure: no solver, no bus, no clock.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Annotated, Any, Literal, TypeVar

import msgspec

from ..errors import FieldIssue, InputError
from . import strict

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator, Mapping

Preemption = Literal["none", "from_start", "from_interrupt", "delete"]
WindowReading = Literal["task", "start"]
PrecedenceKind = Literal["tight", "lax"]
PrecedenceScope = Literal["both", "at_least_first"]
ResourceKind = Literal["binary", "multiple", "consumable"]
T = TypeVar("T")

MIN_COST, MAX_COST = 0, 5
MIN_DELAY_COST, MAX_DELAY_COST = 1, 5

#: Characters allowed in task ids, goal ids, resource names and spacecraft
#: ids. They become Zenoh key chunks (``scheduler/dispatch/<task>``): ``/``
#: would split the key, ``* $ ? #`` are wildcards or refused by Zenoh, and
#: a leading ``@`` marks Zenoh's reserved chunks.
ID_CHARS = "A-Za-z0-9_.-"
#: Longest id accepted. Zenoh fails to send keys of about 64 KiB (a Rust
#: panic in ``put``); ids stay far below that, with room for the prefix.
MAX_ID_LENGTH = 64
_ID_RE = re.compile(f"[{ID_CHARS}]+")
_BAD_ID_CHAR = re.compile(f"[^{ID_CHARS}]")

#: Largest absolute time value (units) in a problem, goal or clock: far
#: beyond any mission, and exact in the solver's double precision.
MAX_TIME = 2**31 - 1

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
#: A time value (units), possibly before the problem start.
Time = Annotated[int, msgspec.Meta(ge=-MAX_TIME, le=MAX_TIME)]
#: A time unit of the mission clock.
Instant = Annotated[int, msgspec.Meta(ge=0, le=MAX_TIME)]
#: A number of time units, at least one.
Units = Annotated[int, msgspec.Meta(ge=1, le=MAX_TIME)]
DelayCost = Annotated[int, msgspec.Meta(ge=MIN_DELAY_COST, le=MAX_DELAY_COST)]
ScheduleCost = Annotated[
    int,
    msgspec.Meta(ge=MIN_COST, le=MAX_COST, description="0 = mandatory"),
]
#: A capacity or a level: never negative.
Amount = Annotated[float, msgspec.Meta(ge=0)]


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
    feasible_interval: tuple[Time, Time] | None = None
    uses: dict[str, float] = {}
    feasible_interval_applies_to: WindowReading | None = None
    fixed_start: Time | None = None

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

    Attributes
    ----------
    initial
        Level at the start of the problem, ``0 <= initial <= max``.
    max
        The ceiling (capacity), ``>= 0``; None for none.
    """

    initial: Amount
    max: Amount | None = None


class Resources(msgspec.Struct, frozen=True, omit_defaults=True):
    """The three resource kinds and their capacities / initial levels.

    A consumable is its initial level (a number: no ceiling) or a
    :class:`Consumable` (initial level and optional capacity); read them
    through :attr:`initial_levels` and :attr:`ceilings`.
    """

    binary: tuple[Id, ...] = ()
    multiple: dict[str, Amount] = {}
    consumable: dict[str, Amount | Consumable] = {}

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


class Problem(msgspec.Struct, frozen=True, omit_defaults=True):
    """A scheduling problem over ``[start, start + horizon)``."""

    horizon: Units
    tasks: tuple[Task, ...]
    start: Instant = 0
    feasible_interval_applies_to: WindowReading = "task"
    resources: Resources = Resources()
    precedences: tuple[Precedence, ...] = ()

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


def shown(value: str, limit: int = 40) -> str:
    """``value`` quoted for a message, cut to ``limit`` characters."""
    if len(value) <= limit:
        return repr(value)
    return f"{value[:limit]!r}... ({len(value)} characters)"


def id_issue(value: str) -> str | None:
    """Why ``value`` is not a key-safe id (None when it is one).

    The grammar: 1 to :data:`MAX_ID_LENGTH` characters out of
    ``[A-Za-z0-9_.-]``.
    """
    if not value:
        return "must not be empty"
    if len(value) > MAX_ID_LENGTH:
        return (
            f"is {len(value)} characters long; ids are at most {MAX_ID_LENGTH}"
        )
    if _ID_RE.fullmatch(value) is None:
        bad = "".join(dict.fromkeys(_BAD_ID_CHAR.findall(value)))
        return (
            f"{shown(value)} has characters outside [{ID_CHARS}] "
            f"({bad!r}); ids are used as bus key chunks"
        )
    return None


def key_path(path: str, key: str) -> str:
    """``path.key`` for a dictionary key (cut when it is not an id)."""
    if id_issue(key) is None:
        return f"{path}.{key}"
    return f"{path}[{shown(key, 20)}]"


_PATH_RE = re.compile(r"- at `\$(?P<path>[^`]*)`")
_GOT_RE = re.compile(r"got `(?P<got>\w+)`")
_MISSING_RE = re.compile(r"missing required field `(?P<field>\w+)`")
_SEGMENT_RE = re.compile(r"\.(?P<name>\w+)|\[(?P<idx>\d+)\]")
_JSON_TYPES = {
    str: "str",
    bool: "bool",
    int: "int",
    float: "float",
    list: "array",
    dict: "object",
    type(None): "null",
}

#: The reason given for a document nested beyond the decoder's limit.
MAX_DEPTH_NOTE = "nested too deeply to decode"


def _msgspec_issue(error: Exception, data: bytes | str) -> FieldIssue:
    """Turn a msgspec decode error into a FieldIssue with a clean path."""
    text = str(error)
    match = _PATH_RE.search(text)
    path = match.group("path").lstrip(".") if match else ""
    reason = _PATH_RE.sub("", text).strip()
    if "[...]" in path:
        path = _name_the_key(path, text, data)
    return FieldIssue(path, reason)


def _name_the_key(path: str, text: str, data: bytes | str) -> str:
    """``path.<key>...`` for msgspec's ``path[...]...`` (a dictionary value).

    msgspec does not say which key of a dictionary holds the wrong value;
    the key is found again in the document: the first whose value (or the
    part of it the rest of the path names) has the JSON type the error
    says it got, or is an object without the field it says is missing.
    """
    prefix, _, suffix = path.partition("[...]")
    got = _GOT_RE.search(text)
    missing = _MISSING_RE.search(text)
    try:
        node = _walk_path(msgspec.json.decode(data), prefix)
    except (msgspec.DecodeError, RecursionError):
        return path
    if not isinstance(node, dict) or (got is None and missing is None):
        return path
    for key, value in node.items():
        target = _walk_path(value, suffix)
        if got is not None:
            found = _JSON_TYPES.get(type(target)) == got["got"]
        else:
            found = (
                isinstance(target, dict)
                and missing is not None
                and (missing["field"] not in target)
            )
        if found:
            return key_path(prefix, key) + suffix
    return path


def _walk_path(node: object, path: str) -> object:
    """The part of a decoded document at ``path`` (``a.b[2]``), or None."""
    for segment in _SEGMENT_RE.finditer(
        path if path.startswith((".", "[")) or not path else "." + path
    ):
        if segment.group("name") is not None and isinstance(node, dict):
            node = node.get(segment.group("name"))
        elif segment.group("idx") is not None and isinstance(node, list):
            idx = int(segment.group("idx"))
            node = node[idx] if idx < len(node) else None
        else:
            node = None
    return node


_DECODERS: dict[type, msgspec.json.Decoder[Any]] = {}


def _decoder(kind: type[T]) -> msgspec.json.Decoder[T]:
    """One decoder per type, built once (the inputs' hot path)."""
    decoder = _DECODERS.get(kind)
    if decoder is None:
        decoder = _DECODERS[kind] = msgspec.json.Decoder(kind)
    return decoder


def read_strict(
    data: bytes | str, kind: type[T], what: str
) -> tuple[T | None, list[FieldIssue], set[str]]:
    """Parse ``data`` and check it against ``kind`` (:mod:`.strict`).

    Returns
    -------
    value, issues, bad
        ``value`` is the decoded document when ``issues`` is empty;
        otherwise a stand-in with every bad part set aside (for the
        semantic rules to run on the rest; never to be used), or None.
        ``bad`` holds the paths of the issues: semantic findings at or
        under them are about stand-ins.
    """
    try:
        raw = msgspec.json.decode(data)
    except msgspec.DecodeError as error:
        issue = strict.syntax_issue(error, data)
        return None, [issue], {""}
    except RecursionError:
        issue = FieldIssue("", f"{MAX_DEPTH_NOTE} (recursion limit reached)")
        return None, [issue], {""}
    issues = strict.shape_issues(raw, kind)
    if issues:
        return (
            strict.repaired(raw, kind, issues),
            issues,
            {issue.path for issue in issues},
        )
    try:
        return msgspec.convert(raw, kind), [], set()
    except msgspec.ValidationError as error:  # a rule in __post_init__
        issue = _msgspec_issue(error, data)
        return None, [issue], {issue.path}


_EVERYWHERE = {"", "horizon", "start", "feasible_interval_applies_to"}


def decode_strict(data: bytes | str, kind: type[T], what: str) -> T:
    """Decode JSON into ``kind``, raising InputError naming every mistake.

    Unknown fields are mistakes (with the closest known name), as are
    wrong types, values outside their declared range or enumeration, and
    missing fields: all of them, in one pass (:mod:`.strict`). A document
    nested deeper than the decoder's recursion limit is bad input too.
    """
    value, issues, _ = read_strict(data, kind, what)
    if issues or value is None:
        raise InputError(issues, what)
    return value


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
    problem, issues, bad = read_strict(data, Problem, "problem")
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


def encode(value: object) -> bytes:
    """Encode a model or plan structure as compact JSON."""
    return msgspec.json.encode(value)


# --------------------------------------------------------------------------
# Validation. Each rule is a generator of FieldIssue; validate_problem runs
# them all so a user sees every mistake at once.


def validate_problem(
    problem: Problem, *, allow_empty: bool = False
) -> list[FieldIssue]:
    """Return every validation issue of ``problem`` (empty when valid)."""
    issues = [
        *_check_horizon(problem),
        *_check_resources(problem.resources),
    ]
    issues += _check_tasks(problem, allow_empty)
    # Tight precedences that contradict along two paths are valid: they
    # only mean those tasks cannot all be scheduled together (see
    # fsw_scheduler.proofs for when that makes the problem infeasible).
    issues += _check_precedences(problem)
    return issues


def _check_horizon(problem: Problem) -> Iterator[FieldIssue]:
    if problem.horizon <= 0:
        yield FieldIssue("horizon", f"must be > 0, got {problem.horizon}")
    if problem.start < 0:
        yield FieldIssue("start", f"must be >= 0, got {problem.start}")
    if problem.start + max(problem.horizon, 0) > MAX_TIME:
        yield FieldIssue(
            "horizon",
            f"start + horizon must be at most {MAX_TIME}, got "
            f"{problem.start + problem.horizon}",
        )


def _check_resources(resources: Resources) -> Iterator[FieldIssue]:
    seen: dict[str, str] = {}
    named = [
        *(("binary", i, n) for i, n in enumerate(resources.binary)),
        *(("multiple", n, n) for n in resources.multiple),
        *(("consumable", n, n) for n in resources.consumable),
    ]
    for kind, key, name in named:
        path = (
            f"resources.{kind}[{key}]"
            if kind == "binary"
            else f"resources.{kind}.{key}"
        )
        reason = id_issue(name)
        if reason is not None:
            if kind != "binary":
                path = key_path(f"resources.{kind}", name)
            yield FieldIssue(path, f"resource name {reason}")
        if name in seen:
            yield FieldIssue(
                path, f"resource {name!r} is already declared as {seen[name]}"
            )
        seen[name] = kind
    for name, capacity in resources.multiple.items():
        if capacity < 0:
            yield FieldIssue(
                key_path("resources.multiple", name),
                f"capacity must be >= 0, got {capacity}",
            )
    for name, spec in resources.consumable.items():
        yield from _check_consumable(name, spec)


def _check_consumable(
    name: str, spec: float | Consumable
) -> Iterator[FieldIssue]:
    path = key_path("resources.consumable", name)
    if not isinstance(spec, Consumable):
        if spec < 0:
            yield FieldIssue(path, f"initial level must be >= 0, got {spec}")
        return
    if spec.initial < 0:
        yield FieldIssue(
            f"{path}.initial",
            f"initial level must be >= 0, got {spec.initial}",
        )
    if spec.max is None:
        return
    if spec.max < 0:
        yield FieldIssue(
            f"{path}.max", f"capacity must be >= 0, got {spec.max}"
        )
    elif spec.initial > spec.max:
        yield FieldIssue(
            f"{path}.initial",
            f"initial level {spec.initial:g} is above the capacity "
            f"max {spec.max:g}",
        )


def _check_tasks(problem: Problem, allow_empty: bool) -> list[FieldIssue]:
    issues: list[FieldIssue] = []
    if not problem.tasks and not allow_empty:
        issues.append(FieldIssue("tasks", "at least one task is required"))
    issues += duplicate_ids(problem.tasks)
    for idx, task in enumerate(problem.tasks):
        issues += _check_task(problem, task, f"tasks[{idx}]")
    return issues


def duplicate_ids(tasks: Iterable[Task]) -> list[FieldIssue]:
    """One issue per task whose id an earlier task already has."""
    issues = []
    seen: dict[str, int] = {}
    for idx, task in enumerate(tasks):
        if task.id in seen:
            issues.append(
                FieldIssue(
                    f"tasks[{idx}].id",
                    f"duplicate task id {shown(task.id)} "
                    f"(first at tasks[{seen[task.id]}])",
                )
            )
        seen.setdefault(task.id, idx)
    return issues


def _check_task(problem: Problem, task: Task, path: str) -> list[FieldIssue]:
    issues: list[FieldIssue] = []
    reason = id_issue(task.id)
    if reason is not None:
        issues.append(FieldIssue(f"{path}.id", f"task id {reason}"))
    issues += time_issues(task, path)
    if task.length <= 0:
        issues.append(
            FieldIssue(f"{path}.length", f"must be > 0, got {task.length}")
        )
    if not MIN_DELAY_COST <= task.delay_cost <= MAX_DELAY_COST:
        issues.append(
            FieldIssue(
                f"{path}.delay_cost",
                f"must be in {MIN_DELAY_COST}..{MAX_DELAY_COST}, "
                f"got {task.delay_cost}",
            )
        )
    if not MIN_COST <= task.schedule_cost <= MAX_COST:
        issues.append(
            FieldIssue(
                f"{path}.schedule_cost",
                f"must be in {MIN_COST}..{MAX_COST} (0 = mandatory), "
                f"got {task.schedule_cost}",
            )
        )
    for name, amount in sorted(task.uses.items()):
        issues += _check_use(problem.resources, name, amount, path)
    if task.length > 0:
        issues += _check_window(problem, task, path)
    return issues


def _check_use(
    resources: Resources, name: str, amount: float, path: str
) -> Iterable[FieldIssue]:
    kind = resources.kind_of(name)
    where = key_path(f"{path}.uses", name)
    if kind is None:
        known = ", ".join(resources.names) or "none declared"
        return [FieldIssue(where, f"unknown resource (known: {known})")]
    if kind == "binary" and amount != 1:
        return [
            FieldIssue(
                where, f"binary resource amount must be 1, got {amount}"
            )
        ]
    if kind == "multiple" and amount < 0:
        return [
            FieldIssue(
                where, f"multiple resource amount must be >= 0, got {amount}"
            )
        ]
    return []


def time_issues(task: Task, path: str) -> list[FieldIssue]:
    """Time values of ``task`` outside ``[-MAX_TIME, MAX_TIME]``."""
    values = {
        "length": task.length,
        "fixed_start": task.fixed_start,
        **dict(
            zip(
                ("feasible_interval[0]", "feasible_interval[1]"),
                task.feasible_interval or (),
                strict=False,
            )
        ),
    }
    return [
        FieldIssue(
            f"{path}.{name}",
            f"{value} is out of range (at most {MAX_TIME} in absolute value)",
        )
        for name, value in values.items()
        if value is not None and abs(value) > MAX_TIME
    ]


def _check_window(
    problem: Problem, task: Task, path: str
) -> Iterable[FieldIssue]:
    if task.length > problem.horizon:
        return [
            FieldIssue(
                f"{path}.length",
                f"length {task.length} exceeds the horizon {problem.horizon}",
            )
        ]
    if task.fixed_start is not None:
        low, high = problem.start, problem.end - task.length
        if not low <= task.fixed_start <= high:
            return [
                FieldIssue(
                    f"{path}.fixed_start",
                    f"must be in [{low}, {high}] to fit the horizon",
                )
            ]
    if task.feasible_interval is None:
        return []
    where = f"{path}.feasible_interval"
    low, high = task.feasible_interval
    if low > high:
        return [FieldIssue(where, f"start {low} is after end {high}")]
    reading = problem.window_reading(task)
    if reading == "task" and high - low < task.length:
        return [
            FieldIssue(
                where,
                f"[{low}, {high}] is {high - low} units long and cannot "
                f"hold the task's length {task.length}",
            )
        ]
    earliest, latest = problem.start_bounds(task)
    if earliest > latest:
        return [
            FieldIssue(
                where,
                f"[{low}, {high}] leaves no start time inside the horizon "
                f"[{problem.start}, {problem.end}) for length {task.length}",
            )
        ]
    return []


def _check_precedences(problem: Problem) -> Iterator[FieldIssue]:
    ids = {task.id for task in problem.tasks}
    for idx, prec in enumerate(problem.precedences):
        path = f"precedences[{idx}]"
        for end in ("before", "after"):
            name = getattr(prec, end)
            if name not in ids:
                yield FieldIssue(
                    f"{path}.{end}", f"unknown task {shown(name)}"
                )
        if prec.before == prec.after:
            yield FieldIssue(
                f"{path}.after", f"task {prec.after!r} cannot precede itself"
            )
