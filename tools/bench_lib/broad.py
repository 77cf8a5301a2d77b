"""A broader problem generator, not tuned to the solver.

The paper-shaped generator (:mod:`bench_lib.generator`) builds every
problem around a witness plan: precedences never contradict, mandatory
tasks never meet, resources rarely bind. This one draws problems the way
an autonomy layer might send them, with the shape the issue lists:

* binary resources about 80 % busy: the lengths of each resource's users
  add up to 70-90 % of the horizon;
* multiple-resource amounts from 1/6 to 0.6 of the capacity;
* consumables whose initial level is about a third of the total demand,
  with generators (negative amounts) whose windows lie early in the
  horizon, so that they must be placed before most consumers can run;
* about 30 % of tasks with a feasible interval (either reading);
* about 0.4 precedences per task, tight or lax, ``both`` or
  ``at_least_first``, offsets from negative to positive, mandatory tasks
  included, and in about one problem in three a pair of tight paths that
  fix the same start difference in two different ways.

Nothing guarantees feasibility: a few problems are infeasible (their
mandatory tasks cannot all be placed), which a solver must prove.
All randomness comes from :class:`random.Random` seeded with integers.
"""

from __future__ import annotations

import random
from typing import Any

MANDATORY_SHARE = 0.2
WINDOW_SHARE = 0.3
PRECEDENCES_PER_TASK = 0.4
CONTRADICTION_SHARE = 0.35
BUSY = (0.7, 0.9)
MAX_LENGTH = 20

BINARY_NAMES = ("camera", "antenna", "position")
MULTIPLE_CAPACITY = {"power": 120, "data_rate": 60}
CONSUMABLE_NAMES = ("battery", "propellant")


def generate_problem(
    num_tasks: int, resource_class: str, horizon: int, seed: int
) -> dict[str, Any]:
    """Generate one problem document of the broad kind.

    Parameters
    ----------
    num_tasks
        Number of tasks (>= 3).
    resource_class
        ``none``, ``binary``, ``multiple``, ``consumable`` or ``mixed``
        (``all`` is the same as ``mixed``).
    horizon
        Horizon length in time units.
    seed
        Integer seed; the same arguments give the same document.

    Returns
    -------
    dict
        A CONTRACT section 1 problem that passes ``decode_problem``.
    """
    rng = random.Random(seed)
    reading = rng.choice(("task", "start"))
    tasks: list[dict[str, Any]] = []
    for idx in range(num_tasks):
        tasks.append(
            {
                "id": f"T{idx:03d}",
                "length": rng.randint(1, min(MAX_LENGTH, horizon)),
                "delay_cost": rng.randint(1, 5),
                "schedule_cost": rng.randint(1, 5),
                "preemption": rng.choice(
                    ("none", "from_start", "from_interrupt", "delete")
                ),
                "uses": {},
            }
        )
    mandatory = rng.sample(
        range(num_tasks), max(1, round(MANDATORY_SHARE * num_tasks))
    )
    for idx in mandatory:
        tasks[idx]["schedule_cost"] = 0
    resources: dict[str, Any] = {}
    mixed = resource_class in ("mixed", "all")
    if mixed or resource_class == "binary":
        names = BINARY_NAMES[: rng.randint(1, 2) if not mixed else 3]
        resources["binary"] = list(names)
        _binary(rng, tasks, names, horizon, mixed)
    if mixed or resource_class == "multiple":
        names = tuple(MULTIPLE_CAPACITY)[: rng.randint(1, 2)]
        resources["multiple"] = {n: MULTIPLE_CAPACITY[n] for n in names}
        _multiple(rng, tasks, names)
    generators: set[int] = set()
    if mixed or resource_class == "consumable":
        names = CONSUMABLE_NAMES[: rng.randint(1, 2)]
        resources["consumable"], generators = _consumable(
            rng, tasks, names, horizon
        )
    for idx, task in enumerate(tasks):
        if idx in generators:
            continue  # windows already set
        if rng.random() < WINDOW_SHARE:
            _window(rng, task, reading, horizon)
    precedences = _precedences(rng, tasks)
    return {
        "horizon": horizon,
        "start": 0,
        "feasible_interval_applies_to": reading,
        "resources": resources,
        "tasks": tasks,
        "precedences": precedences,
    }


def _binary(
    rng: random.Random,
    tasks: list[dict[str, Any]],
    names: tuple[str, ...],
    horizon: int,
    mixed: bool,
) -> None:
    """Users of each binary resource fill 70-90 % of the horizon."""
    for name in names:
        share = 0.3 if mixed else 0.6
        users = [t for t in tasks if rng.random() < share]
        if len(users) < 2:
            users = rng.sample(tasks, min(2, len(tasks)))
        busy = round(rng.uniform(*BUSY) * horizon)
        cap = horizon // 2
        # Stretch the users' lengths to the wanted load, none longer than
        # half the horizon (what a capped task cannot take, the others do).
        for _ in range(len(users)):
            total = sum(t["length"] for t in users)
            open_ = [t for t in users if t["length"] < cap]
            if total >= busy or not open_:
                break
            scale = (busy - total) / sum(t["length"] for t in open_)
            for task in open_:
                grown = task["length"] + max(1, round(task["length"] * scale))
                task["length"] = min(cap, grown)
        for task in users:
            task["uses"][name] = 1


def _multiple(
    rng: random.Random, tasks: list[dict[str, Any]], names: tuple[str, ...]
) -> None:
    for task in tasks:
        for name in names:
            if rng.random() < 0.7:
                cap = MULTIPLE_CAPACITY[name]
                task["uses"][name] = rng.randint(cap // 6, 3 * cap // 5)


def _consumable(
    rng: random.Random,
    tasks: list[dict[str, Any]],
    names: tuple[str, ...],
    horizon: int,
) -> tuple[dict[str, int], set[int]]:
    """Consumers, early generators, initial level a third of the demand."""
    levels: dict[str, int] = {}
    count = max(1, round(0.15 * len(tasks)))
    optional = [
        i for i, t in enumerate(tasks) if t["schedule_cost"] > 0
    ] or list(range(len(tasks)))
    generators = set(rng.sample(optional, min(count, len(optional))))
    for position, name in enumerate(names):
        demand = must = 0
        for idx, task in enumerate(tasks):
            if idx in generators:
                if position == 0:
                    task["uses"][name] = -rng.randint(4, 10)
                continue
            if rng.random() < (0.7 if position == 0 else 0.35):
                amount = rng.randint(1, 5 if position == 0 else 3)
                task["uses"][name] = amount
                demand += amount * task["length"]
                if task["schedule_cost"] == 0:
                    must += amount * task["length"]
        # Mandatory consumers alone fit in the initial level, so that most
        # problems stay feasible; the optional ones compete for the rest.
        levels[name] = max(1, round(demand * rng.uniform(0.28, 0.4)), must + 1)
    for idx in generators:
        task = tasks[idx]
        # Early: the window closes within the first third of the horizon.
        high = rng.randint(
            task["length"] + 5, max(task["length"] + 5, horizon // 3)
        )
        task["feasible_interval"] = [0, min(horizon, high)]
        task["feasible_interval_applies_to"] = "task"
    return levels, generators


def _window(
    rng: random.Random, task: dict[str, Any], reading: str, horizon: int
) -> None:
    length = task["length"]
    span = rng.randint(length + 2, max(length + 2, horizon // 3))
    span = min(span, horizon)
    low = rng.randint(0, horizon - span)
    high = low + span
    own = reading
    if rng.random() < 0.2:
        own = "start" if reading == "task" else "task"
        task["feasible_interval_applies_to"] = own
    task["feasible_interval"] = [low, high]


def _offset(rng: random.Random, before: dict[str, Any]) -> int:
    roll = rng.random()
    if roll < 0.4:
        return 0
    if roll < 0.7:
        return rng.randint(1, 10)
    return -rng.randint(1, before["length"])


def _precedences(
    rng: random.Random, tasks: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """About 0.4 per task, in a random order of the tasks (no lax cycle).

    Tight and lax, both scopes, any offset; mandatory tasks may be on
    either end. One problem in three gets a tight triangle whose two paths
    contradict.
    """
    order = list(range(len(tasks)))
    rng.shuffle(order)
    rank = {idx: pos for pos, idx in enumerate(order)}
    wanted = max(1, round(PRECEDENCES_PER_TASK * len(tasks)))
    seen: set[tuple[int, int]] = set()
    edges: list[dict[str, Any]] = []

    def add(a: int, b: int, kind: str, scope: str, offset: int) -> None:
        seen.add((a, b))
        edges.append(
            {
                "before": tasks[a]["id"],
                "after": tasks[b]["id"],
                "kind": kind,
                "scope": scope,
                "offset": offset,
            }
        )

    optional = [i for i, t in enumerate(tasks) if t["schedule_cost"] > 0]
    if len(optional) >= 3 and rng.random() < CONTRADICTION_SHARE:
        a, b, c = sorted(rng.sample(optional, 3), key=rank.__getitem__)
        ab = _offset(rng, tasks[a])
        bc = _offset(rng, tasks[b])
        ac = tasks[a]["length"] + ab + tasks[b]["length"] + bc
        ac += rng.choice((-3, -2, -1, 1, 2, 3))  # the other path disagrees
        scope = rng.choice(("both", "at_least_first"))
        add(a, b, "tight", scope, ab)
        add(b, c, "tight", rng.choice(("both", "at_least_first")), bc)
        add(a, c, "tight", scope, ac - tasks[a]["length"])
    tries = 0
    while len(edges) < wanted and tries < 20 * wanted:
        tries += 1
        a, b = rng.sample(range(len(tasks)), 2)
        if rank[a] > rank[b]:
            a, b = b, a
        if (a, b) in seen:
            continue
        kind = "tight" if rng.random() < 0.4 else "lax"
        scope = rng.choice(("both", "at_least_first"))
        offset = _offset(rng, tasks[a])
        if tasks[b]["schedule_cost"] == 0 or (
            tasks[a]["schedule_cost"] == 0 and scope == "both"
        ):
            # An edge that forces a task in: mostly turned down (always
            # at scale, where they would chain), else a lax one without a
            # window on the forced side, so that few problems become
            # infeasible.
            if len(tasks) > 20 or rng.random() < 0.85:
                continue
            kind, offset = "lax", abs(offset)
            for end in (a, b):
                if tasks[end]["schedule_cost"] > 0:
                    tasks[end].pop("feasible_interval", None)
                    tasks[end].pop("feasible_interval_applies_to", None)
        add(a, b, kind, scope, offset)
    return edges
