"""Small problems that use every feature at once, for agreement checks.

The campaign generators draw the paper's shapes; this one draws what the
mission model added on top, all mixed in one problem, small enough that
CP-SAT and CBC both prove every answer in a fraction of a second:

* 3 to ``max_tasks`` tasks over horizons of 12 to ``max_horizon`` units;
* one to three resource kinds: binary resources, some with
  ``available`` windows (one or two); a multiple resource, sometimes
  with a capacity step down; a consumable with an ``initial`` level,
  sometimes a ``max`` and an ``external`` charge over a stretch, used by
  consumers and generators (negative amounts);
* about a quarter of tasks mandatory, every preemption policy, a third
  with a feasible interval in either reading;
* up to one precedence per task, of every kind and scope, offsets from
  -3 to 3 (contradictions included: some problems are infeasible);
* in about a third of the problems a group of alternatives (one task
  against one or two), whose cost may be 0 (an option is mandatory).

Used by ``tests/system/test_bench.py`` to check that CBC and CP-SAT
prove the same optimum, the same infeasibility, and that the checker
accepts every plan. All randomness comes from :class:`random.Random`
seeded with integers.
"""

from __future__ import annotations

import random
from typing import Any

#: Largest default problem: more would leave CP-SAT's proof, not the
#: agreement, as what a test waits for.
MAX_TASKS = 8
MAX_HORIZON = 40


def generate_problem(
    seed: int, max_tasks: int = MAX_TASKS, max_horizon: int = MAX_HORIZON
) -> dict[str, Any]:
    """Draw one problem document with the features of the module docstring.

    Parameters
    ----------
    seed
        Integer seed; the same arguments give the same document.
    max_tasks
        Most tasks (at least 3).
    max_horizon
        Longest horizon (at least 20).

    Returns
    -------
    dict
        A problem document that passes ``decode_problem``.
    """
    rng = random.Random(seed)
    horizon = rng.randint(12, max_horizon)
    resources = _resources(rng, horizon)
    tasks = [
        _task(rng, idx, horizon, resources)
        for idx in range(rng.randint(3, max_tasks))
    ]
    precedences = []
    for _ in range(rng.randint(0, len(tasks))):
        before, after = rng.sample(range(len(tasks)), 2)
        precedences.append(
            {
                "before": f"t{before}",
                "after": f"t{after}",
                "kind": rng.choice(("tight", "lax")),
                "scope": rng.choice(("both", "at_least_first")),
                "offset": rng.randint(-3, 3),
            }
        )
    doc: dict[str, Any] = {
        "horizon": horizon,
        "start": 0,
        "feasible_interval_applies_to": rng.choice(("task", "start")),
        "resources": resources,
        "tasks": tasks,
        "precedences": precedences,
    }
    if len(tasks) >= 4 and rng.random() < 0.35:
        ids = rng.sample([task["id"] for task in tasks], 3)
        options = [[ids[0]], ids[1:] if rng.random() < 0.5 else [ids[1]]]
        members = {name for option in options for name in option}
        for task in tasks:
            if task["id"] in members:
                # A member's cost is the group's: left out of the member.
                del task["schedule_cost"]
        doc["alternatives"] = [
            {
                "id": "g0",
                "schedule_cost": rng.choice((0, 2, 5)),
                "options": options,
            }
        ]
    return doc


def _resources(rng: random.Random, horizon: int) -> dict[str, Any]:
    kinds = rng.sample(("binary", "multiple", "consumable"), rng.randint(1, 3))
    resources: dict[str, Any] = {}
    if "binary" in kinds:
        binary: dict[str, Any] = {}
        for name in rng.sample(("camera", "antenna"), rng.randint(1, 2)):
            binary[name] = {}
            if rng.random() < 0.4:
                opens = rng.randint(0, horizon // 2)
                closes = rng.randint(opens + 2, horizon)
                windows = [[opens, closes]]
                if closes + 4 < horizon and rng.random() < 0.5:
                    windows.append([closes + 3, horizon])
                binary[name] = {"available": windows}
        resources["binary"] = binary
    if "multiple" in kinds:
        capacity = rng.choice((5, 10, 12))
        value: Any = capacity
        if rng.random() < 0.4:
            lower = capacity - rng.randint(1, capacity - 1)
            value = {
                "steps": [[0, capacity], [rng.randint(1, horizon - 1), lower]]
            }
        resources["multiple"] = {"power": value}
    if "consumable" in kinds:
        battery: dict[str, Any] = {"initial": rng.randint(0, 20)}
        if rng.random() < 0.4:
            battery["max"] = battery["initial"] + rng.randint(0, 15)
        if rng.random() < 0.3:
            since = rng.randint(0, horizon - 2)
            battery["external"] = [
                [since, rng.randint(1, 3)],
                [rng.randint(since + 1, horizon), 0],
            ]
        resources["consumable"] = {"battery": battery}
    return resources


def _task(
    rng: random.Random, idx: int, horizon: int, resources: dict[str, Any]
) -> dict[str, Any]:
    uses: dict[str, float] = {}
    for name in resources.get("binary", {}):
        if rng.random() < 0.5:
            uses[name] = 1
    for name in resources.get("multiple", {}):
        if rng.random() < 0.6:
            uses[name] = rng.randint(1, 8)
    for name in resources.get("consumable", {}):
        draw = rng.random()
        if draw < 0.5:
            uses[name] = rng.randint(1, 4)
        elif draw < 0.7:
            uses[name] = -rng.randint(1, 4)
    task: dict[str, Any] = {
        "id": f"t{idx}",
        "length": rng.randint(1, 6),
        "delay_cost": rng.randint(1, 5),
        "schedule_cost": 0 if rng.random() < 0.25 else rng.randint(1, 5),
        "preemption": rng.choice(
            ("none", "from_start", "from_interrupt", "delete")
        ),
        "uses": uses,
    }
    if rng.random() < 0.35:
        opens = rng.randint(0, horizon - 8)
        task["feasible_interval"] = [opens, rng.randint(opens + 7, horizon)]
        if rng.random() < 0.5:
            task["feasible_interval_applies_to"] = rng.choice(
                ("task", "start")
            )
    return task
