"""The mission suite: campaign problems given the fields of the mission model.

Two classes, side by side with the campaign's:

``alternatives``
    A paper-campaign problem (binary, multiple and consumable classes in
    turn) whose optional tasks outside every precedence are paired into
    groups of two one-task options (up to three groups), each group
    costing the larger of its two schedule costs.
``profiles``
    The same problems with their resources made to change over time: each
    binary resource unavailable for 30 units after the first third of
    the horizon, each multiple capacity at 60 % in the middle third, and
    each consumable starting at 60 % of its level with an external charge
    (its initial level spread over the horizon) in the first half.

Sizes 5, 10 and 15 at H = 336, 7 problems per cell, named
``m15-profiles-3``; each is rebuilt alone from its own seed, byte for
byte (the transformations draw nothing).
"""

from __future__ import annotations

import copy
import random
from typing import Any

MISSION_CLASSES = ("alternatives", "profiles")
BASE_CLASSES = ("binary", "multiple", "consumable")
MAX_GROUPS = 3


def with_alternatives(doc: dict[str, Any]) -> dict[str, Any]:
    """``doc`` with pairs of optional, unlinked tasks made alternatives."""
    doc = copy.deepcopy(doc)
    linked = {
        name
        for prec in doc.get("precedences", [])
        for name in (prec["before"], prec["after"])
    }
    free = [
        task
        for task in doc["tasks"]
        if task["schedule_cost"] > 0
        and task["id"] not in linked
        and "fixed_start" not in task
    ]
    groups = []
    for k in range(min(len(free) // 2, MAX_GROUPS)):
        first, second = free[2 * k], free[2 * k + 1]
        cost = max(first["schedule_cost"], second["schedule_cost"])
        first["schedule_cost"] = second["schedule_cost"] = cost
        groups.append(
            {
                "id": f"G{k}",
                "schedule_cost": cost,
                "options": [[first["id"]], [second["id"]]],
            }
        )
    doc["alternatives"] = groups
    return doc


def with_profiles(doc: dict[str, Any]) -> dict[str, Any]:
    """``doc`` with windows, capacity steps and external rates."""
    doc = copy.deepcopy(doc)
    start, horizon = doc.get("start", 0), doc["horizon"]
    third = horizon // 3
    res = doc.setdefault("resources", {})
    if res.get("binary"):
        res["binary"] = {
            name: {
                "available": [
                    [start, start + third],
                    [start + third + 30, start + horizon],
                ]
            }
            for name in res["binary"]
        }
    if res.get("multiple"):
        res["multiple"] = {
            name: {
                "steps": [
                    [start, int(cap)],
                    [start + third, int(cap * 0.6)],
                    [start + 2 * third, int(cap)],
                ]
            }
            for name, cap in res["multiple"].items()
        }
    if res.get("consumable"):
        stores = {}
        for name, spec in res["consumable"].items():
            level = spec if isinstance(spec, int | float) else spec["initial"]
            stores[name] = {
                "initial": round(level * 0.6, 3),
                "external": [
                    [start, round(level / horizon, 3)],
                    [start + horizon // 2, 0],
                ],
            }
        res["consumable"] = stores
    return doc


def with_orbit(doc: dict[str, Any], seed: int) -> dict[str, Any]:
    """``doc`` under an orbit drawn from ``seed``: each binary resource
    available in passes of a twelfth to a fifth of the horizon with gaps
    of 5-25 units between them, and each constant multiple capacity at
    70 % in every other stretch of a tenth to a fifth of the horizon
    (eclipses). Consumables stay as they are."""
    doc = copy.deepcopy(doc)
    rng = random.Random(seed)
    start, horizon = doc.get("start", 0), doc["horizon"]
    end = start + horizon
    res = doc["resources"]
    binary = res.get("binary") or []
    if isinstance(binary, list):
        passes = {}
        for name in binary:
            windows, t = [], start + rng.randint(0, 30)
            while t < end:
                width = rng.randint(horizon // 12, horizon // 5)
                windows.append([t, min(end, t + width)])
                t += width + rng.randint(5, 25)
            passes[name] = {"available": windows}
        res["binary"] = passes
    for name, cap in list(res.get("multiple", {}).items()):
        if not isinstance(cap, int | float):
            continue
        steps, t, sunlit = [], start, True
        while t < end:
            steps.append([t, cap if sunlit else int(cap * 0.7)])
            t += rng.randint(horizon // 10, horizon // 5)
            sunlit = not sunlit
        res["multiple"][name] = {"steps": steps}
    return doc
