"""Problems of the shape an autonomy layer sends: a battery to charge first.

Three binary resources, ``power`` (a multiple resource, capacity 60) and
``battery`` (a consumable, initial level 40), about 35 % of tasks with a
window, ``n // 3`` precedences, 10 % of tasks mandatory. Consumers drain
the battery faster than it is charged, so a mandatory consumer often
needs more than the initial level and must wait for generators. Seeded
with integers only: the same arguments give the same document.
"""

from __future__ import annotations

import random
from typing import Any

BINARY = ("camera", "antenna", "thruster")
POWER = 60
BATTERY = 40


def fresh_doc(num_tasks: int, horizon: int, seed: int) -> dict[str, Any]:
    """Draw one problem document of the fresh shape.

    Parameters
    ----------
    num_tasks
        Number of tasks (>= 2).
    horizon
        Horizon length in time units (>= 100).
    seed
        Integer seed.

    Returns
    -------
    dict
        A valid problem document (feasibility is not guaranteed).
    """
    rng = random.Random(seed)
    mandatory = set(
        rng.sample(range(num_tasks), max(1, round(num_tasks / 10)))
    )
    tasks = []
    for idx in range(num_tasks):
        length = rng.randint(5, min(60, horizon // 4))
        uses: dict[str, float] = {
            name: 1 for name in BINARY if rng.random() < 0.3
        }
        if rng.random() < 0.5:
            uses["power"] = rng.choice((10, 15, 20, 30, 40))
        if rng.random() < 0.6:
            charge = rng.random() < 0.3
            uses["battery"] = (
                -rng.choice((1, 2, 3)) if charge else rng.choice((1, 2, 3, 4))
            )
        task: dict[str, Any] = {
            "id": f"t{idx:02d}",
            "length": length,
            "schedule_cost": 0 if idx in mandatory else rng.randint(1, 5),
            "delay_cost": rng.randint(1, 3),
        }
        if uses:
            task["uses"] = uses
        if rng.random() < 0.35:
            low = rng.randint(0, horizon - length)
            high = min(horizon, low + length + rng.randint(0, horizon // 3))
            task["feasible_interval"] = [low, high]
        tasks.append(task)
    precedences = []
    for _ in range(num_tasks // 3):
        before, after = sorted(rng.sample(range(num_tasks), 2))
        precedences.append(
            {
                "before": f"t{before:02d}",
                "after": f"t{after:02d}",
                "kind": rng.choice(("tight", "lax")),
                "scope": rng.choice(("both", "at_least_first")),
                "offset": rng.randint(-5, 30),
            }
        )
    return {
        "horizon": horizon,
        "feasible_interval_applies_to": "task",
        "resources": {
            "binary": list(BINARY),
            "multiple": {"power": POWER},
            "consumable": {"battery": BATTERY},
        },
        "tasks": tasks,
        "precedences": precedences,
    }
