"""Seeded generator of benchmark problems (the problem format documents).

Two suites:

``campaign``
    The paper's test campaign: 5, 10 and 15 tasks x five resource classes
    (``none``, ``binary``, ``multiple``, ``consumable``, and ``all``: every
    kind at once) x 7 problems, with a horizon of 336 time units.
``scaling``
    30, 60, 100 and 200 tasks at H = 336 and H = 1440 with every resource
    kind present (class ``mixed``).

Every problem is built around a *witness*: start times for every task that
satisfy all windows and all precedences at once (resources ignored), so the
precedences never contradict each other or the windows. Mandatory tasks
(``schedule_cost`` 0) take part in no precedence that could force another
task in, get disjoint witness slots, fit the multiple-resource capacities
and are covered by the consumables' initial levels; the plan holding only
the mandatory tasks at their witness starts is therefore always valid.

Each problem has its own integer seed (``BenchProblem.seed``), and
``generate_problem(num_tasks, resource_class, horizon, seed)`` rebuilds it
alone, byte for byte. All randomness comes from :class:`random.Random`
seeded with integers; no set or hash ordering is involved.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import random
import zlib
from dataclasses import dataclass
from typing import Any

from fsw_scheduler.model.problem import Problem, decode_problem

from . import broad, fresh, infeasible, mission

#: The campaign's resource classes: the paper's four, and ``all`` (every
#: kind at once, each generator's ``mixed`` shape).
CLASSES: tuple[str, ...] = ("none", "binary", "multiple", "consumable", "all")
CAMPAIGN_SIZES: tuple[int, ...] = (5, 10, 15)
CAMPAIGN_PER_CELL = 7
CAMPAIGN_HORIZON = 336
SCALING_SIZES: tuple[int, ...] = (30, 60, 100, 200)
SCALING_HORIZONS: tuple[int, ...] = (336, 1440)
SCALING_PER_POINT = 3
#: The large suite: parts past the neighbourhood search's threshold, in
#: the fresh (``f``) and broad (``b``, class ``mixed``) shapes.
LARGE_SIZES: tuple[int, ...] = (30, 45, 60)
LARGE_HORIZONS: tuple[int, ...] = (1440, 2880)

MAX_LENGTH = 20
MANDATORY_SHARE = 0.2
WINDOW_SHARE = 0.4

BINARY_NAMES = ("camera", "antenna", "position")
MULTIPLE_CAPACITY = {"power": 100, "data_rate": 60}
CONSUMABLE_NAMES = ("battery", "propellant")


@dataclass(frozen=True)
class BenchProblem:
    """One generated benchmark problem.

    Attributes
    ----------
    name
        Unique name inside its suite, e.g. ``c10-binary-3``.
    suite
        ``campaign``, ``scaling`` or ``quick``.
    num_tasks
        Number of tasks.
    resource_class
        ``none``, ``binary``, ``multiple``, ``consumable`` or ``mixed``.
    horizon
        Horizon length in time units.
    seed
        The problem's own seed: ``generate_problem(num_tasks,
        resource_class, horizon, seed)`` returns the same document.
    doc
        The problem document (problem format) as a dict.
    """

    name: str
    suite: str
    num_tasks: int
    resource_class: str
    horizon: int
    seed: int
    doc: dict[str, Any]

    def to_json(self) -> bytes:
        """Return the problem document as deterministic JSON bytes."""
        return dump_json(self.doc)

    def problem(self) -> Problem:
        """Return the decoded and validated problem."""
        return decode_problem(self.to_json())


def dump_json(doc: dict[str, Any]) -> bytes:
    """Serialise ``doc`` deterministically (two-space indent, newline)."""
    return (json.dumps(doc, indent=2) + "\n").encode()


def problem_seed(seed: int, name: str) -> int:
    """Derive a problem's own seed from the suite seed and its name."""
    return zlib.crc32(f"{seed}/{name}".encode())


def campaign(seed: int = 0, style: str = "paper") -> list[BenchProblem]:
    """Return the paper's campaign: sizes x classes x 7 problems, H = 336.

    Parameters
    ----------
    seed
        Suite seed; the same seed always gives the same problems.
    style
        ``paper`` (this module's witness-based generator) or ``broad``
        (:mod:`bench_lib.broad`, names prefixed ``b``).

    Returns
    -------
    list of BenchProblem
        105 problems, ordered by size, then class, then index.
    """
    prefix = "b" if style == "broad" else "c"
    problems = []
    for size in CAMPAIGN_SIZES:
        for cls in CLASSES:
            for index in range(CAMPAIGN_PER_CELL):
                name = f"{prefix}{size:02d}-{cls}-{index}"
                problems.append(
                    _make(
                        name,
                        "campaign",
                        size,
                        cls,
                        CAMPAIGN_HORIZON,
                        seed,
                        style,
                    )
                )
    return problems


def scaling(
    seed: int = 0, per_point: int = SCALING_PER_POINT, style: str = "paper"
) -> list[BenchProblem]:
    """Return the scaling set: 30..200 tasks at H = 336 and 1440, mixed.

    Parameters
    ----------
    seed
        Suite seed.
    per_point
        Problems per (size, horizon) point.
    style
        ``paper`` or ``broad`` (names prefixed ``b``), as for
        :func:`campaign`.

    Returns
    -------
    list of BenchProblem
        Ordered by horizon, then size, then index.
    """
    prefix = "bs" if style == "broad" else "s"
    problems = []
    for horizon in SCALING_HORIZONS:
        for size in SCALING_SIZES:
            for index in range(per_point):
                name = f"{prefix}{size:03d}-h{horizon}-{index}"
                problems.append(
                    _make(name, "scaling", size, "mixed", horizon, seed, style)
                )
    return problems


def large_suite(seed: int = 0) -> list[BenchProblem]:
    """Return the large suite: :data:`LARGE_SIZES` tasks x
    :data:`LARGE_HORIZONS`, one fresh-shaped (``f30-h1440``) and one
    broad mixed problem (``b30-h1440``) each, ordered by horizon, then
    size, fresh first: 12 problems, most of them one part of 30 tasks or
    more (the neighbourhood search's and its bounds' ground)."""
    problems = []
    for horizon in LARGE_HORIZONS:
        for size in LARGE_SIZES:
            name = f"f{size}-h{horizon}"
            own_seed = problem_seed(seed, name)
            doc = fresh.generate_problem(size, horizon, own_seed)
            problems.append(
                BenchProblem(
                    name, "large", size, "mixed", horizon, own_seed, doc
                )
            )
            problems.append(
                _make(
                    f"b{size}-h{horizon}",
                    "large",
                    size,
                    "mixed",
                    horizon,
                    seed,
                    "broad",
                )
            )
    return problems


def orbit_suite(seed: int = 0) -> list[BenchProblem]:
    """Return the large suite under an orbit: each problem of
    :func:`large_suite` with passes on its binary resources and eclipses
    on its multiple ones (:func:`.mission.with_orbit`, drawn from the
    problem's own seed), named ``o`` + its name (``of30-h1440``)."""
    return [
        dataclasses.replace(
            bench,
            name=f"o{bench.name}",
            suite="orbit",
            doc=mission.with_orbit(bench.doc, problem_seed(seed, bench.name)),
        )
        for bench in large_suite(seed)
    ]


#: Problems per kind of the infeasible suite.
INFEASIBLE_PER_KIND = 2


def infeasible_suite(seed: int = 0) -> list[BenchProblem]:
    """Return the infeasible suite: :data:`INFEASIBLE_PER_KIND` problems
    of each kind of :mod:`bench_lib.infeasible` (30-60 tasks, H up to
    2,880, an impossible core of mandatory tasks in optional noise), 28
    in all. Every solver must answer ``infeasible``: ``unknown`` is a
    miss."""
    problems = []
    for kind in infeasible.KINDS:
        for idx in range(INFEASIBLE_PER_KIND):
            name = f"x-{kind}-{idx}"
            own_seed = problem_seed(seed, name)
            doc = infeasible.generate_problem(kind, own_seed)
            problems.append(
                BenchProblem(
                    name,
                    "infeasible",
                    len(doc["tasks"]),
                    kind,
                    doc["horizon"],
                    own_seed,
                    doc,
                )
            )
    return problems


def quick(seed: int = 0, style: str = "paper") -> list[BenchProblem]:
    """Return a small smoke subset: one 5-task problem per class."""
    prefix = "bq" if style == "broad" else "q"
    return [
        _make(
            f"{prefix}05-{cls}-0",
            "quick",
            5,
            cls,
            CAMPAIGN_HORIZON,
            seed,
            style,
        )
        for cls in CLASSES
    ]


STYLES: tuple[str, ...] = ("paper", "broad", "fresh")


def fresh_campaign(
    seed: int = 0, per_cell: int = fresh.PER_CELL
) -> list[BenchProblem]:
    """Return the fresh campaign (:mod:`bench_lib.fresh`), class ``mixed``.

    Sizes x horizons x ``per_cell`` problems, named ``f15-h336-0``,
    ordered by size, then horizon, then index.
    """
    problems = []
    for size in fresh.SIZES:
        for horizon in fresh.HORIZONS:
            for index in range(per_cell):
                name = f"f{size:02d}-h{horizon}-{index}"
                own_seed = problem_seed(seed, name)
                doc = fresh.generate_problem(size, horizon, own_seed)
                problems.append(
                    BenchProblem(
                        name, "campaign", size, "mixed", horizon, own_seed, doc
                    )
                )
    return problems


def mission_suite(seed: int = 0) -> list[BenchProblem]:
    """Return the mission suite (:mod:`bench_lib.mission`): sizes 5, 10,
    15 x classes ``alternatives`` and ``profiles`` x 7 problems, H = 336,
    each a paper-style problem of a base class (binary, multiple,
    consumable in turn) given the fields of the mission model."""
    problems = []
    for size in CAMPAIGN_SIZES:
        for cls in mission.MISSION_CLASSES:
            for index in range(CAMPAIGN_PER_CELL):
                name = f"m{size:02d}-{cls}-{index}"
                own_seed = problem_seed(seed, name)
                base = mission.BASE_CLASSES[index % len(mission.BASE_CLASSES)]
                doc = generate_problem(size, base, CAMPAIGN_HORIZON, own_seed)
                doc = (
                    mission.with_alternatives(doc)
                    if cls == "alternatives"
                    else mission.with_profiles(doc)
                )
                problems.append(
                    BenchProblem(
                        name,
                        "mission",
                        size,
                        cls,
                        CAMPAIGN_HORIZON,
                        own_seed,
                        doc,
                    )
                )
    return problems


def suite(
    name: str, seed: int = 0, style: str = "paper"
) -> list[BenchProblem]:
    """Return the problems of suite ``name`` (campaign/scaling/all/quick).

    ``style`` chooses the generator: ``paper``, ``broad`` or ``fresh``
    (a campaign only: ``all`` is its campaign, ``quick`` its first
    problem, and it has no scaling set).
    """
    if style not in STYLES:
        raise ValueError(f"unknown style {style!r}")
    if style == "fresh":
        if name in ("campaign", "all"):
            return fresh_campaign(seed)
        if name == "quick":
            first = fresh_campaign(seed, per_cell=1)[0]
            return [dataclasses.replace(first, suite="quick")]
        raise ValueError(f"the fresh generator has no {name!r} suite")
    if name == "campaign":
        return campaign(seed, style)
    if name == "scaling":
        return scaling(seed, style=style)
    if name == "all":
        return campaign(seed, style) + scaling(seed, style=style)
    if name == "quick":
        return quick(seed, style)
    if name == "mission":
        return mission_suite(seed)
    if name == "large":
        return large_suite(seed)
    if name == "orbit":
        return orbit_suite(seed)
    if name == "infeasible":
        return infeasible_suite(seed)
    raise ValueError(f"unknown suite {name!r}")


def _make(
    name: str,
    suite_name: str,
    size: int,
    cls: str,
    horizon: int,
    seed: int,
    style: str = "paper",
) -> BenchProblem:
    own_seed = problem_seed(seed, name)
    if style == "broad":
        doc = broad.generate_problem(size, cls, horizon, own_seed)
    else:
        doc = generate_problem(size, cls, horizon, own_seed)
    return BenchProblem(name, suite_name, size, cls, horizon, own_seed, doc)


# --------------------------------------------------------------------------
# One problem.


@dataclass
class _Task:
    index: int
    length: int
    delay_cost: int
    schedule_cost: int
    preemption: str
    rank: float = 0.0
    start: int = 0  # witness start
    window: tuple[int, int] | None = None
    reading: str | None = None  # per-task override of the window reading
    uses: dict[str, int] | None = None

    @property
    def id(self) -> str:
        return f"T{self.index:03d}"

    @property
    def mandatory(self) -> bool:
        return self.schedule_cost == 0


@dataclass
class _Edge:
    before: int
    after: int
    kind: str
    scope: str
    offset: int


def generate_problem(
    num_tasks: int, resource_class: str, horizon: int, seed: int
) -> dict[str, Any]:
    """Generate one problem document.

    Parameters
    ----------
    num_tasks
        Number of tasks (>= 1).
    resource_class
        ``none``, ``binary``, ``multiple``, ``consumable`` or ``mixed``
        (``all`` is the same as ``mixed``).
    horizon
        Horizon length; task lengths are 1..20.
    seed
        Integer seed; the same arguments give the same document.

    Returns
    -------
    dict
        A the problem format problem that passes ``decode_problem``.
    """
    if resource_class not in (*CLASSES, "mixed"):
        raise ValueError(f"unknown resource class {resource_class!r}")
    if resource_class == "all":
        resource_class = "mixed"
    rng = random.Random(seed)
    reading = rng.choice(("task", "start"))
    tasks = _make_tasks(rng, num_tasks, horizon)
    _place_mandatory(rng, tasks, horizon)
    edges = _make_edges(rng, tasks)
    edges = _place_witness(rng, tasks, edges, horizon)
    _make_windows(rng, tasks, reading, horizon)
    resources = _make_resources(rng, tasks, edges, resource_class)
    return {
        "horizon": horizon,
        "start": 0,
        "feasible_interval_applies_to": reading,
        "resources": resources,
        "tasks": [_task_doc(task) for task in tasks],
        "precedences": [
            {
                "before": tasks[edge.before].id,
                "after": tasks[edge.after].id,
                "kind": edge.kind,
                "scope": edge.scope,
                "offset": edge.offset,
            }
            for edge in edges
        ],
    }


def _make_tasks(
    rng: random.Random, num_tasks: int, horizon: int
) -> list[_Task]:
    max_length = min(MAX_LENGTH, horizon)
    tasks = [
        _Task(
            index=i,
            length=rng.randint(1, max_length),
            delay_cost=rng.randint(1, 5),
            schedule_cost=rng.randint(1, 5),
            preemption=rng.choice(
                ("none", "from_start", "from_interrupt", "delete")
            ),
            rank=rng.random(),
        )
        for i in range(num_tasks)
    ]
    # Mandatory tasks: about a fifth, at least one, their total length at
    # most half the horizon so that disjoint witness slots exist.
    wanted = max(1, round(MANDATORY_SHARE * num_tasks))
    budget = horizon // 2
    for index in rng.sample(range(num_tasks), wanted):
        if tasks[index].length <= budget:
            tasks[index].schedule_cost = 0
            budget -= tasks[index].length
    return tasks


def _place_mandatory(
    rng: random.Random, tasks: list[_Task], horizon: int
) -> None:
    """Give mandatory tasks disjoint witness slots in random order."""
    mandatory = [task for task in tasks if task.mandatory]
    rng.shuffle(mandatory)
    free = horizon - sum(task.length for task in mandatory)
    cuts = sorted(rng.randint(0, free) for _ in mandatory)
    time, used = 0, 0
    for task, cut in zip(mandatory, cuts, strict=True):
        time += cut - used
        used = cut
        task.start = time
        time += task.length


def _tight_offset(rng: random.Random, before: _Task) -> int:
    roll = rng.random()
    if roll < 0.4:
        return 0
    if roll < 0.7 or before.length == 1:
        return rng.randint(1, 5)
    return -rng.randint(1, before.length - 1)  # the two tasks overlap


def _lax_offset(rng: random.Random, before: _Task) -> int:
    roll = rng.random()
    if roll < 0.4:
        return 0
    if roll < 0.7:
        return rng.randint(1, 10)
    return -rng.randint(1, before.length)


def _make_edges(rng: random.Random, tasks: list[_Task]) -> list[_Edge]:
    """Tight chains and lax edges, all following increasing rank.

    Mandatory tasks appear only as ``before`` of lax ``at_least_first``
    edges, which never force another task into the plan.
    """
    optional = [task for task in tasks if not task.mandatory]
    rng.shuffle(optional)
    edges: list[_Edge] = []
    # Tight chains of 2-3 tasks, built forward in rank order; each task is
    # in at most one chain, so tight offsets can never contradict.
    pos = 0
    for _ in range(max(1, len(tasks) // 5)):
        size = rng.randint(2, 3)
        chain = optional[pos : pos + size]
        if len(chain) < 2:
            break
        pos += size
        chain.sort(key=lambda task: task.rank)
        for before, after in itertools.pairwise(chain):
            edges.append(
                _Edge(
                    before.index,
                    after.index,
                    "tight",
                    rng.choice(("both", "at_least_first")),
                    _tight_offset(rng, before),
                )
            )
    # Lax edges between any two tasks, in rank order.
    seen = {(edge.before, edge.after) for edge in edges}
    for _ in range(max(1, len(tasks) // 4)):
        first, second = rng.sample(tasks, 2)
        if first.rank > second.rank:
            first, second = second, first
        if second.mandatory or (first.index, second.index) in seen:
            continue
        scope = (
            "at_least_first"
            if first.mandatory
            else rng.choice(("both", "at_least_first"))
        )
        seen.add((first.index, second.index))
        edges.append(
            _Edge(
                first.index,
                second.index,
                "lax",
                scope,
                _lax_offset(rng, first),
            )
        )
    return edges


def _place_witness(
    rng: random.Random, tasks: list[_Task], edges: list[_Edge], horizon: int
) -> list[_Edge]:
    """Choose witness starts for optional tasks; drop edges that cannot hold.

    Tasks are visited in rank order, so every predecessor is placed first.
    Returns the kept edges, in their original order.
    """
    incoming: dict[int, list[_Edge]] = {}
    for edge in edges:
        incoming.setdefault(edge.after, []).append(edge)
    dropped: list[_Edge] = []
    for task in sorted(tasks, key=lambda t: t.rank):
        if task.mandatory:
            continue
        latest = horizon - task.length
        preds = incoming.get(task.index, [])

        def bound(edge: _Edge) -> int:
            before = tasks[edge.before]
            return before.start + before.length + edge.offset

        tight = [edge for edge in preds if edge.kind == "tight"]
        lax = sorted(
            (edge for edge in preds if edge.kind == "lax"),
            key=lambda e: (bound(e), e.before),
        )
        if tight and not 0 <= bound(tight[0]) <= latest:
            dropped.append(tight[0])
            tight = []
        if tight:
            task.start = bound(tight[0])
            for edge in lax:
                if bound(edge) > task.start:
                    dropped.append(edge)
            continue
        while lax and bound(lax[-1]) > latest:
            dropped.append(lax.pop())
        if lax:
            earliest = max(0, bound(lax[-1]))
            task.start = rng.randint(earliest, min(latest, earliest + 40))
        else:
            task.start = rng.randint(0, latest)
    return [edge for edge in edges if all(edge is not d for d in dropped)]


def _make_windows(
    rng: random.Random, tasks: list[_Task], reading: str, horizon: int
) -> None:
    """Windows around the witness placement, in either reading."""
    other = "start" if reading == "task" else "task"
    for task in tasks:
        if rng.random() >= WINDOW_SHARE:
            continue
        own = reading
        if rng.random() < 0.2:
            own = other
            task.reading = other
        slack = 3 * task.length + 20
        low = max(0, task.start - rng.randint(0, slack))
        if own == "task":
            high = min(
                horizon, task.start + task.length + rng.randint(0, slack)
            )
        else:
            high = min(horizon, task.start + rng.randint(0, slack))
        task.window = (low, high)


def _make_resources(
    rng: random.Random,
    tasks: list[_Task],
    edges: list[_Edge],
    resource_class: str,
) -> dict[str, Any]:
    for task in tasks:
        task.uses = {}
    resources: dict[str, Any] = {}
    mixed = resource_class == "mixed"
    if mixed or resource_class == "binary":
        names = BINARY_NAMES[: rng.randint(2, 3)]
        resources["binary"] = list(names)
        _use_binary(rng, tasks, edges, names)
    if mixed or resource_class == "multiple":
        names = tuple(MULTIPLE_CAPACITY)[: rng.randint(1, 2)]
        resources["multiple"] = {
            name: MULTIPLE_CAPACITY[name] for name in names
        }
        _use_multiple(rng, tasks, edges, names)
    if mixed or resource_class == "consumable":
        names = CONSUMABLE_NAMES[: rng.randint(1, 2)]
        resources["consumable"] = _use_consumable(rng, tasks, names)
    return resources


def _overlapping_pairs(
    tasks: list[_Task], edges: list[_Edge]
) -> list[tuple[_Task, _Task]]:
    """Tight pairs with a negative offset: they always run together."""
    return [
        (tasks[edge.before], tasks[edge.after])
        for edge in edges
        if edge.kind == "tight" and edge.offset < 0
    ]


def _use_binary(
    rng: random.Random,
    tasks: list[_Task],
    edges: list[_Edge],
    names: tuple[str, ...],
) -> None:
    for task in tasks:
        assert task.uses is not None
        for name in names:
            if rng.random() < 0.4:
                task.uses[name] = 1
    for before, after in _overlapping_pairs(tasks, edges):
        assert before.uses is not None and after.uses is not None
        for name in names:
            if name in before.uses:
                after.uses.pop(name, None)


def _use_multiple(
    rng: random.Random,
    tasks: list[_Task],
    edges: list[_Edge],
    names: tuple[str, ...],
) -> None:
    for task in tasks:
        assert task.uses is not None
        for name in names:
            if rng.random() < 0.7:
                cap = MULTIPLE_CAPACITY[name]
                task.uses[name] = rng.randint(cap // 10, 3 * cap // 5)
    for before, after in _overlapping_pairs(tasks, edges):
        assert before.uses is not None and after.uses is not None
        for name in names:
            room = MULTIPLE_CAPACITY[name] - before.uses.get(name, 0)
            if after.uses.get(name, 0) > room:
                after.uses[name] = room


def _use_consumable(
    rng: random.Random, tasks: list[_Task], names: tuple[str, ...]
) -> dict[str, int]:
    """Consumers, charging tasks (negative amounts) and initial levels.

    The initial level covers every mandatory consumer in full plus a random
    share of the optional consumption, so the resource binds but the
    mandatory tasks always fit.
    """
    levels: dict[str, int] = {}
    chargers = {task.index for task in tasks if rng.random() < 0.2} or {
        rng.randrange(len(tasks))
    }
    for position, name in enumerate(names):
        mandatory_need = optional_need = 0
        for task in tasks:
            assert task.uses is not None
            if position == 0 and task.index in chargers:
                task.uses[name] = -rng.randint(5, 10)
                continue
            share = 0.7 if position == 0 else 0.3
            if rng.random() < share:
                amount = rng.randint(1, 5 if position == 0 else 3)
                task.uses[name] = amount
                if task.mandatory:
                    mandatory_need += amount * task.length
                else:
                    optional_need += amount * task.length
        levels[name] = mandatory_need + round(
            optional_need * rng.uniform(0.25, 0.6)
        )
    return levels


def _task_doc(task: _Task) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "id": task.id,
        "length": task.length,
        "delay_cost": task.delay_cost,
        "schedule_cost": task.schedule_cost,
        "preemption": task.preemption,
        "feasible_interval": list(task.window) if task.window else None,
        "uses": task.uses or {},
    }
    if task.reading is not None:
        doc["feasible_interval_applies_to"] = task.reading
    return doc
