"""Fresh problem shapes, tuned to neither solver (``--generator fresh``).

The paper and broad campaigns have been looked at while the ILP was
tuned; these shapes were not, so that a comparison with CP-SAT on them
says how the model does on problems it has not been fitted to:

* every problem has three binary resources, a ``power`` multiple resource
  of capacity :data:`POWER` and a ``battery`` consumable of
  :data:`BATTERY` (one early charging task among the users);
* about :data:`WINDOW_SHARE` of tasks have a feasible interval;
* n/3 precedences, tight and lax, both scopes, offsets of either sign,
  in a random order of the tasks (no lax cycle);
* :data:`MANDATORY_SHARE` of tasks are mandatory, and their battery use
  alone fits in the battery;
* horizons :data:`HORIZONS`, sizes :data:`SIZES`, task lengths up to
  1/16 of the horizon.

Nothing guarantees feasibility. All randomness comes from
:class:`random.Random` seeded with integers.
"""

from __future__ import annotations

import random
from typing import Any

from .broad import _offset, _window

SIZES: tuple[int, ...] = (15, 20, 25)
HORIZONS: tuple[int, ...] = (336, 1440)
PER_CELL = 3

BINARY_NAMES = ("camera", "antenna", "position")
POWER = 60
BATTERY = 40
WINDOW_SHARE = 0.35
MANDATORY_SHARE = 0.1
BINARY_SHARE = 0.35
POWER_SHARE = 0.6
BATTERY_SHARE = 0.4


def generate_problem(num_tasks: int, horizon: int, seed: int) -> dict:
    """Generate one problem document of the fresh kind.

    Parameters
    ----------
    num_tasks
        Number of tasks (>= 3).
    horizon
        Horizon length in time units.
    seed
        Integer seed; the same arguments give the same document.

    Returns
    -------
    dict
        A problem document that passes ``decode_problem``.
    """
    rng = random.Random(seed)
    reading = rng.choice(("task", "start"))
    longest = max(2, horizon // 16)
    tasks: list[dict[str, Any]] = [
        {
            "id": f"T{idx:03d}",
            "length": rng.randint(1, longest),
            "delay_cost": rng.randint(1, 5),
            "schedule_cost": rng.randint(1, 5),
            "preemption": rng.choice(
                ("none", "from_start", "from_interrupt", "delete")
            ),
            "uses": {},
        }
        for idx in range(num_tasks)
    ]
    mandatory = set(
        rng.sample(
            range(num_tasks), max(1, round(MANDATORY_SHARE * num_tasks))
        )
    )
    for idx in mandatory:
        tasks[idx]["schedule_cost"] = 0
    for name in BINARY_NAMES:
        users = [t for t in tasks if rng.random() < BINARY_SHARE]
        for task in users or rng.sample(tasks, 2):
            task["uses"][name] = 1
    for task in tasks:
        if rng.random() < POWER_SHARE:
            task["uses"]["power"] = rng.randint(POWER // 6, 3 * POWER // 5)
    charger = rng.choice([i for i in range(num_tasks) if i not in mandatory])
    _battery(rng, tasks, mandatory, charger, horizon)
    for idx, task in enumerate(tasks):
        if idx != charger and rng.random() < WINDOW_SHARE:
            _window(rng, task, reading, horizon)
    return {
        "horizon": horizon,
        "start": 0,
        "feasible_interval_applies_to": reading,
        "resources": {
            "binary": list(BINARY_NAMES),
            "multiple": {"power": POWER},
            "consumable": {"battery": BATTERY},
        },
        "tasks": tasks,
        "precedences": _precedences(rng, tasks, mandatory),
    }


def _battery(
    rng: random.Random,
    tasks: list[dict[str, Any]],
    mandatory: set[int],
    charger: int,
    horizon: int,
) -> None:
    """Consumers per time unit, mandatory ones within the battery, and one
    charging task whose window closes in the first third."""
    must = 0
    for idx, task in enumerate(tasks):
        if idx == charger or rng.random() >= BATTERY_SHARE:
            continue
        amount = rng.randint(1, 2)
        if idx in mandatory:
            if must + amount * task["length"] >= BATTERY:
                continue
            must += amount * task["length"]
        task["uses"]["battery"] = amount
    task = tasks[charger]
    task["uses"]["battery"] = -rng.randint(1, 3)
    high = rng.randint(
        task["length"] + 5, max(task["length"] + 5, horizon // 3)
    )
    task["feasible_interval"] = [0, min(horizon, high)]
    task["feasible_interval_applies_to"] = "task"


def _precedences(
    rng: random.Random, tasks: list[dict[str, Any]], mandatory: set[int]
) -> list[dict[str, Any]]:
    """n/3 edges along a random order; none that forces an optional task
    in (its ``after`` mandatory, or a ``both`` edge from a mandatory one)."""
    order = list(range(len(tasks)))
    rng.shuffle(order)
    rank = {idx: pos for pos, idx in enumerate(order)}
    wanted = len(tasks) // 3
    seen: set[tuple[int, int]] = set()
    edges: list[dict[str, Any]] = []
    tries = 0
    while len(edges) < wanted and tries < 50 * wanted:
        tries += 1
        a, b = sorted(rng.sample(range(len(tasks)), 2), key=rank.__getitem__)
        scope = rng.choice(("both", "at_least_first"))
        if (a, b) in seen or b in mandatory:
            continue
        if a in mandatory and scope == "both":
            continue
        seen.add((a, b))
        edges.append(
            {
                "before": tasks[a]["id"],
                "after": tasks[b]["id"],
                "kind": rng.choice(("tight", "lax")),
                "scope": scope,
                "offset": _offset(rng, tasks[a]),
            }
        )
    return edges
