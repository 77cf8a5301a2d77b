"""Odd shapes: problems of every field's corner, for ``tools/fuzz``.

The campaign generators draw problems of a few families at fixed
horizons; these draw any mix the format allows, at sizes where CP-SAT
answers at once: 4-22 tasks, horizons of 20-700 units starting at 0-100
(or, ``large``, 30-60 tasks over 120-2,880 units, where neither solver
always proves its answer in 20 s), zero to three cameras (some with
availability windows), zero to two multiple resources (some with
capacity steps), zero to two consumables (some with a ceiling and
external charge; some tasks generate), windows on the start or on the
whole task, tight and lax precedences of both scopes with offsets of
either sign, and now and then a group of alternatives. Nothing
guarantees feasibility. All randomness comes from :class:`random.Random`
seeded with the problem's number.
"""

from __future__ import annotations

import random
from typing import Any

#: Horizons drawn from.
HORIZONS = (20, 40, 60, 120, 300, 700)
#: Problem starts drawn from.
STARTS = (0, 0, 5, 100)
#: Task counts and horizons of the large shapes (``tools/fuzz --large``):
#: the sizes the large, orbit and replan suites measure, drawn as freely.
LARGE_SIZES = (30, 60)
LARGE_HORIZONS = (120, 300, 700, 1440, 2880)


def generate_problem(seed: int, large: bool = False) -> dict[str, Any]:
    """Problem ``seed`` as a JSON-ready dict; ``large``: of
    :data:`LARGE_SIZES` tasks over one of :data:`LARGE_HORIZONS`, drawn
    otherwise the same way."""
    rng = random.Random(seed)
    size = rng.randint(*LARGE_SIZES) if large else rng.randint(4, 22)
    horizon = rng.choice(LARGE_HORIZONS if large else HORIZONS)
    start = rng.choice(STARTS)
    resources, binary, multiple, consumable = _resources(rng, start, horizon)
    tasks = [
        _task(rng, idx, start, horizon, binary, multiple, consumable)
        for idx in range(size)
    ]
    doc: dict[str, Any] = {
        "horizon": horizon,
        "start": start,
        "resources": resources,
        "tasks": tasks,
        "precedences": _precedences(rng, size),
    }
    if rng.random() < 0.2:
        ids = [task["id"] for task in tasks]
        rng.shuffle(ids)
        cost = rng.randint(0, 4)
        doc["alternatives"] = [
            {
                "id": "group0",
                "schedule_cost": cost,
                "options": [[ids[0]], [ids[1], ids[2]]],
            }
        ]
        for task in tasks:
            if task["id"] in ids[:3]:
                task["schedule_cost"] = cost  # a member's is the group's
    return doc


def _resources(
    rng: random.Random, start: int, horizon: int
) -> tuple[dict[str, Any], list[str], dict[str, int], list[str]]:
    resources: dict[str, Any] = {}
    binary = [f"cam{idx}" for idx in range(rng.randint(0, 3))]
    if binary and rng.random() < 0.3:
        middle = start + horizon // 2
        resources["binary"] = {
            name: {
                "available": [
                    [start + 2, middle],
                    [middle + 3, start + horizon],
                ]
            }
            if rng.random() < 0.5
            else {}
            for name in binary
        }
    elif binary:
        resources["binary"] = binary
    multiple: dict[str, int] = {}
    written: dict[str, Any] = {}
    for idx in range(rng.randint(0, 2)):
        capacity = rng.choice([3, 10, 60, 100])
        multiple[f"power{idx}"] = capacity
        if rng.random() < 0.25:
            written[f"power{idx}"] = {
                "steps": [
                    [start, capacity],
                    [start + horizon // 3, max(1, capacity // 2)],
                    [start + 2 * horizon // 3, capacity],
                ]
            }
        else:
            written[f"power{idx}"] = capacity
    if written:
        resources["multiple"] = written
    consumable: dict[str, Any] = {}
    for idx in range(rng.randint(0, 2)):
        level = rng.choice([5, 20, 50])
        draw = rng.random()
        if draw < 0.3:
            consumable[f"battery{idx}"] = {"initial": level, "max": 2 * level}
        elif draw < 0.45:
            consumable[f"battery{idx}"] = {
                "initial": level,
                "max": 2 * level,
                "external": [[start + horizon // 2, 1]],
            }
        else:
            consumable[f"battery{idx}"] = level
    if consumable:
        resources["consumable"] = consumable
    return resources, binary, multiple, list(consumable)


def _task(
    rng: random.Random,
    idx: int,
    start: int,
    horizon: int,
    binary: list[str],
    multiple: dict[str, int],
    consumable: list[str],
) -> dict[str, Any]:
    longest = max(1, min(horizon // 3, rng.choice([3, 8, 20, 60])))
    length = rng.randint(1, longest)
    uses: dict[str, float] = {}
    for name in binary:
        if rng.random() < 0.4:
            uses[name] = 1
    for name, capacity in multiple.items():
        if rng.random() < 0.5:
            uses[name] = rng.randint(1, capacity)
    for name in consumable:
        if rng.random() < 0.4:
            uses[name] = rng.choice([0.5, 1, 2, -1])
    task: dict[str, Any] = {
        "id": f"t{idx}",
        "length": length,
        "delay_cost": rng.randint(1, 5),
        "schedule_cost": rng.randint(0, 5) if rng.random() > 0.15 else 0,
        "preemption": rng.choice(
            ["none", "delete", "from_start", "from_interrupt"]
        ),
        "uses": uses,
    }
    if rng.random() < 0.4:
        end = start + horizon
        low = rng.randint(start, end - length)
        reach = rng.choice([length, length + 5, horizon])
        high = rng.randint(low, min(end, low + reach))
        if rng.random() < 0.5:
            task["feasible_interval"] = [low, max(high, low + length)]
            task["feasible_interval_applies_to"] = "task"
        else:
            task["feasible_interval"] = [low, min(high, end - length)]
            task["feasible_interval_applies_to"] = "start"
    return task


def _precedences(rng: random.Random, size: int) -> list[dict[str, Any]]:
    found: dict[tuple[str, str], dict[str, Any]] = {}
    for _ in range(rng.randint(0, size // 2 + 1)):
        first, second = sorted(rng.sample(range(size), 2))
        key = (f"t{first}", f"t{second}")
        found.setdefault(
            key,
            {
                "before": key[0],
                "after": key[1],
                "kind": rng.choice(["tight", "lax"]),
                "scope": rng.choice(["both", "at_least_first"]),
                "offset": rng.randint(-3, 5),
            },
        )
    return list(found.values())


def replan_change(
    doc: dict[str, Any], plan: dict[str, Any], seed: int
) -> tuple[int, dict[str, Any]]:
    """A change to replan problem ``doc`` with, and the unit it comes at.

    ``plan`` is the plan in force as ``{"activities": [{"task", "start",
    "end"}, ...]}``. The unit is drawn between the problem's start and the
    end of its last activity. Drawn from the same seed:

    * 6 in 10: a goal of two of the problem's own tasks cloned under new
      ids, without their windows or fixed starts (so every generator's
      resources fit), one in three made mandatory;
    * 2 in 10: ``activity_failed`` for an activity running at that unit
      (a goal when none runs);
    * 2 in 10: ``levels`` of a consumable measured at a level drawn from
      0 to its ceiling (or its initial level; a goal when there is
      none).
    """
    rng = random.Random(seed * 7 + 1)
    start = doc["start"]
    activities = plan["activities"]
    last = max((a["end"] for a in activities), default=start + 1)
    now = rng.randint(start, max(start + 1, last))
    draw = rng.random()
    running = [a for a in activities if a["start"] <= now < a["end"]]
    consumables = doc["resources"].get("consumable", {})
    if draw < 0.2 and running:
        failed = rng.choice(running)
        return now, {
            "event": "activity_failed",
            "task": failed["task"],
            "at": now,
        }
    if draw < 0.4 and consumables:
        name = rng.choice(sorted(consumables))
        spec = consumables[name]
        ceiling = (
            spec.get("max") or spec["initial"]
            if isinstance(spec, dict)
            else spec
        )
        top = float(ceiling)
        level = round(rng.uniform(0, top), 1)
        return now, {"event": "levels", "levels": {name: level}, "at": now}
    picks = rng.sample(doc["tasks"], k=min(2, len(doc["tasks"])))
    tasks = []
    for idx, task in enumerate(picks):
        clone = {
            key: value
            for key, value in task.items()
            if key
            not in (
                "fixed_start",
                "feasible_interval",
                "feasible_interval_applies_to",
            )
        }
        clone["id"] = f"G{seed}-{idx}"
        if rng.random() < 1 / 3:
            clone["schedule_cost"] = 0
        tasks.append(clone)
    return now, {"goal_id": f"goal-{seed}", "tasks": tasks}
