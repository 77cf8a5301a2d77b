"""Problems of 30-60 tasks that hold one impossible core, by construction.

Each problem is optional noise (tasks on two binary, two multiple and one
consumable resource, some windows and lax or tight precedences) around a
*core* of mandatory tasks that no plan can hold, of one of these kinds:

``lanes``
    k tasks needing just over 1/(m+1) of a multiple resource (at most m
    at once) in a window shorter than their length over m lanes.
``rounds``
    five tasks at 34 % of a multiple resource (two at once) in a window
    one unit shorter than three lengths: the lanes hold their total, but
    one lane must take three of them.
``apart``
    three to six tasks above half of a multiple resource (no two at
    once) in a window shorter than their total length.
``chain``
    a lax chain of three to seven tasks whose first and last windows
    leave one unit too little for it.
``cycle``
    two to four tasks in a lax cycle with offsets of 0-3.
``battery``
    three to eight consumers of more than the battery holds.
``late_supply``
    consumers that must run before the only generator can.
``antenna``
    passes on a binary resource whose two windows hold half of them
    each, less a unit.
``pinned``
    two pinned tasks that overlap on a binary resource.
``tight``
    a tight chain whose last task's window it cannot reach.
``group``
    a mandatory group of two options, each kept out by a pinned task.
``energy``
    six to nine tasks of mixed amounts (a fifth to under half of a
    multiple resource: two, three or four fit at once) whose work in a
    common window is more than its capacity allows there.
``packing``
    one more task than a binary resource has passes, each pass shorter
    than two of them: the passes hold their total length, but none
    holds two.
``clash``
    tasks that no two can share a time for different reasons (a camera
    for some, the power for others, both between the two sets) in a
    window shorter than their total length.

Not tuned on by the proofs: the kinds are those a mission planner meets
(the issue's shapes and their generalisations), drawn with sizes,
horizons (240 to 2,880) and positions from the seed.
"""

from __future__ import annotations

import random
from typing import Any

#: The kinds of impossible core, in suite order.
KINDS = (
    "lanes",
    "rounds",
    "apart",
    "chain",
    "cycle",
    "battery",
    "late_supply",
    "antenna",
    "pinned",
    "tight",
    "group",
    "energy",
    "packing",
    "clash",
)

BINARY = ("cam", "ant")
MULTIPLE = {"power": 100, "bus": 12}
BATTERY = 500


def generate_problem(kind: str, seed: int) -> dict[str, Any]:
    """One problem document of ``kind`` (see the module docstring).

    Parameters
    ----------
    kind
        One of :data:`KINDS`.
    seed
        The problem's seed: the same arguments give the same document.

    Returns
    -------
    dict
        A problem document (problem format) that no plan can satisfy.
    """
    rng = random.Random(f"{kind}/{seed}")
    horizon = rng.choice((240, 720, 1440, 2880))
    size = rng.randint(30, 60)
    core, precedences, groups, windows = _CORES[kind](rng, horizon)
    tasks = core + _noise(rng, size - len(core), horizon)
    noise_ids = [t["id"] for t in tasks if t["id"].startswith("N")]
    for _ in range(rng.randint(0, size // 3)):
        before, after = rng.sample(noise_ids, 2)
        precedences.append(
            {
                "before": before,
                "after": after,
                "kind": rng.choice(("lax", "tight")),
                "scope": "at_least_first",
                "offset": rng.randint(0, 5),
            }
        )
    binary: Any = list(BINARY)
    if windows:
        binary = {"cam": {}, "ant": {"available": windows}}
    doc: dict[str, Any] = {
        "horizon": horizon,
        "start": 0,
        "feasible_interval_applies_to": "task",
        "resources": {
            "binary": binary,
            "multiple": dict(MULTIPLE),
            "consumable": {"bat": BATTERY},
        },
        "tasks": tasks,
        "precedences": precedences,
    }
    if groups:
        doc["alternatives"] = groups
    return doc


def _task(name: str, length: int, uses: dict[str, float], **more: Any) -> dict:
    task = {
        "id": name,
        "length": length,
        "delay_cost": 1,
        "schedule_cost": 0,
        "uses": uses,
    }
    task.update(more)
    return task


def _noise(rng: random.Random, count: int, horizon: int) -> list[dict]:
    tasks = []
    for idx in range(count):
        length = rng.randint(3, max(4, horizon // 40))
        uses: dict[str, float] = {}
        for name in BINARY:
            if rng.random() < 0.25:
                uses[name] = 1
        for name, capacity in MULTIPLE.items():
            if rng.random() < 0.4:
                uses[name] = rng.randint(1, capacity // 2)
        if rng.random() < 0.3:
            uses["bat"] = rng.randint(1, 5)
        task = {
            "id": f"N{idx:03d}",
            "length": length,
            "delay_cost": rng.randint(1, 5),
            "schedule_cost": rng.randint(1, 5),
            "uses": uses,
        }
        if rng.random() < 0.3:
            low = rng.randint(0, horizon - length - 1)
            high = rng.randint(
                low + length, min(horizon, low + length + horizon // 4)
            )
            task["feasible_interval"] = [low, high]
        tasks.append(task)
    return tasks


Core = tuple[list[dict], list[dict], list[dict], list[list[int]]]


def _window(rng: random.Random, horizon: int, width: int) -> list[int]:
    low = rng.randint(0, horizon - width - 1)
    return [low, low + width]


def _lanes(rng: random.Random, horizon: int) -> Core:
    lanes = rng.randint(2, 3)
    count = rng.randint(lanes + 2, lanes + 5)
    length = rng.randint(5, 20)
    window = _window(rng, horizon, count * length // lanes - rng.randint(1, 3))
    amount = MULTIPLE["power"] // (lanes + 1) + 1
    core = [
        _task(f"H{i}", length, {"power": amount}, feasible_interval=window)
        for i in range(count)
    ]
    return core, [], [], []


def _rounds(rng: random.Random, horizon: int) -> Core:
    length = rng.randint(5, 15)
    window = _window(rng, horizon, 3 * length - 1)
    core = [
        _task(f"H{i}", length, {"power": 34}, feasible_interval=window)
        for i in range(5)
    ]
    return core, [], [], []


def _apart(rng: random.Random, horizon: int) -> Core:
    lengths = [rng.randint(4, 25) for _ in range(rng.randint(3, 6))]
    window = _window(rng, horizon, sum(lengths) - rng.randint(1, 3))
    core = [
        _task(
            f"H{i}", n, {"bus": rng.randint(7, 12)}, feasible_interval=window
        )
        for i, n in enumerate(lengths)
    ]
    return core, [], [], []


def _chain(rng: random.Random, horizon: int) -> Core:
    lengths = [rng.randint(4, 30) for _ in range(rng.randint(3, 7))]
    window = _window(rng, horizon, sum(lengths) - 1)
    core = [_task(f"H{i}", n, {}) for i, n in enumerate(lengths)]
    core[0]["feasible_interval"] = window
    core[-1]["feasible_interval"] = window
    precedences = [
        _lax(f"H{i - 1}", f"H{i}", 0) for i in range(1, len(lengths))
    ]
    return core, precedences, [], []


def _lax(before: str, after: str, offset: int) -> dict:
    return {
        "before": before,
        "after": after,
        "kind": "lax",
        "scope": "at_least_first",
        "offset": offset,
    }


def _cycle(rng: random.Random, horizon: int) -> Core:
    count = rng.randint(2, 4)
    core = [_task(f"H{i}", rng.randint(3, 9), {}) for i in range(count)]
    precedences = [
        _lax(f"H{i}", f"H{(i + 1) % count}", rng.randint(0, 3))
        for i in range(count)
    ]
    return core, precedences, [], []


def _battery(rng: random.Random, horizon: int) -> Core:
    count = rng.randint(3, 8)
    core = [
        _task(f"H{i}", rng.randint(2, 10), {"bat": BATTERY // count + 1})
        for i in range(count)
    ]
    return core, [], [], []


def _late_supply(rng: random.Random, horizon: int) -> Core:
    count = rng.randint(2, 5)
    width = rng.randint(20, 60)
    low = rng.randint(0, horizon // 3)
    window = [low, low + width]
    core = [
        _task(
            f"H{i}",
            rng.randint(2, 6),
            {"bat": (BATTERY + 100) // count + 1},
            feasible_interval=window,
        )
        for i in range(count)
    ]
    core.append(
        _task(
            "G",
            5,
            {"bat": -400},
            feasible_interval=[low + width, low + width + 40],
        )
    )
    return core, [], [], []


def _antenna(rng: random.Random, horizon: int) -> Core:
    lengths = [rng.randint(3, 10) for _ in range(rng.randint(2, 5))]
    low = rng.randint(0, horizon - 200)
    half = sum(lengths) // 2
    windows = [[low, low + half], [low + half + 50, low + 2 * half + 49]]
    core = [_task(f"H{i}", n, {"ant": 1}) for i, n in enumerate(lengths)]
    return core, [], [], windows


def _pinned(rng: random.Random, horizon: int) -> Core:
    length = rng.randint(5, 15)
    start = rng.randint(0, horizon - 2 * length)
    core = [
        _task("H0", length, {"cam": 1}, fixed_start=start),
        _task("H1", length, {"cam": 1}, fixed_start=start + length - 1),
    ]
    return core, [], [], []


def _tight(rng: random.Random, horizon: int) -> Core:
    lengths = [rng.randint(3, 12) for _ in range(rng.randint(2, 5))]
    total = sum(lengths)
    low = rng.randint(0, horizon - 3 * total - 4 * len(lengths) - 10)
    core = [_task(f"H{i}", n, {}) for i, n in enumerate(lengths)]
    core[0]["feasible_interval"] = [low, low + lengths[0] + 2]
    far = low + total + 4 * len(lengths) + 5
    core[-1]["feasible_interval"] = [far, far + 2 * total]
    precedences = [
        {
            "before": f"H{i - 1}",
            "after": f"H{i}",
            "kind": "tight",
            "scope": "both",
            "offset": rng.randint(0, 4),
        }
        for i in range(1, len(lengths))
    ]
    return core, precedences, [], []


def _group(rng: random.Random, horizon: int) -> Core:
    length = rng.randint(5, 10)
    start = rng.randint(0, horizon - 3 * length)
    core = [_task("H0", length, {"cam": 1}, fixed_start=start)]
    for name, window in (
        ("H1", [start + 1, start + length + 1]),
        ("H2", [start, start + length + 2]),
    ):
        member = _task(name, length, {"cam": 1}, feasible_interval=window)
        del member["schedule_cost"]  # a member's cost is its group's
        core.append(member)
    group = {"id": "g0", "schedule_cost": 0, "options": [["H1"], ["H2"]]}
    return core, [], [group], []


def _energy(rng: random.Random, horizon: int) -> Core:
    count = rng.randint(6, 9)
    amounts = [rng.randint(20, 45) for _ in range(count)]
    lengths = [rng.randint(5, 20) for _ in range(count)]
    work = sum(a * n for a, n in zip(amounts, lengths, strict=True))
    width = max(max(lengths), work // MULTIPLE["power"] - rng.randint(1, 3))
    window = _window(rng, horizon, width)
    core = [
        _task(f"H{i}", n, {"power": a}, feasible_interval=window)
        for i, (a, n) in enumerate(zip(amounts, lengths, strict=True))
    ]
    return core, [], [], []


def _packing(rng: random.Random, horizon: int) -> Core:
    passes = rng.randint(2, 5)
    length = rng.randint(4, 12)
    width = 2 * length - 1  # one task fits, two do not
    room = (horizon - 1) // passes - width - 1
    gap = rng.randint(1, max(1, min(40, room)))
    low = rng.randint(0, horizon - passes * (width + gap) - 1)
    windows = [
        [low + k * (width + gap), low + k * (width + gap) + width]
        for k in range(passes)
    ]
    core = [_task(f"H{i}", length, {"ant": 1}) for i in range(passes + 1)]
    return core, [], [], windows


def _clash(rng: random.Random, horizon: int) -> Core:
    count = rng.randint(3, 6)
    lengths = [rng.randint(4, 15) for _ in range(count)]
    window = _window(rng, horizon, sum(lengths) - rng.randint(1, 3))
    core = [
        _task(
            f"H{i}",
            n,
            {"cam": 1, "power": 45} if i % 2 else {"power": 60},
            feasible_interval=window,
        )
        for i, n in enumerate(lengths)
    ]
    return core, [], [], []


_CORES = {
    "lanes": _lanes,
    "rounds": _rounds,
    "apart": _apart,
    "chain": _chain,
    "cycle": _cycle,
    "battery": _battery,
    "late_supply": _late_supply,
    "antenna": _antenna,
    "pinned": _pinned,
    "tight": _tight,
    "group": _group,
    "energy": _energy,
    "packing": _packing,
    "clash": _clash,
}
