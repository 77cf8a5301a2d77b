"""Resources that change over time: capacity and external-rate profiles.

A binary resource may have availability windows, a multiple resource a
step profile of capacities, a consumable an external rate (charge that no
task causes). This module turns each into one value per time unit of a
horizon, the one reading every part of the scheduler uses (the checker
reads the raw fields itself). Pure: no solver, no bus, no clock.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence

    from .problem import Resources

__all__ = [
    "capacity_profile",
    "changing",
    "external_profile",
    "peak_capacity",
    "step_values",
    "windows_profile",
]


def step_values(
    steps: Sequence[tuple[int, float]],
    start: int,
    horizon: int,
    before: float = 0.0,
) -> list[float]:
    """One value per unit of ``[start, start + horizon)`` from steps.

    Step ``[t_k, v_k]`` holds during ``[t_k, t_{k+1})``, the last one to
    the end; ``before`` holds before the first step.
    """
    values = [before] * horizon
    for k, (since, value) in enumerate(steps):
        until = steps[k + 1][0] if k + 1 < len(steps) else start + horizon
        for t in range(max(since, start), min(until, start + horizon)):
            values[t - start] = float(value)
    return values


def windows_profile(
    windows: Sequence[tuple[int, int]] | None, start: int, horizon: int
) -> list[float]:
    """1 in every unit inside a window ``[a, b)``, 0 elsewhere.

    ``None`` (no windows given) is available in every unit.
    """
    if windows is None:
        return [1.0] * horizon
    values = [0.0] * horizon
    for low, high in windows:
        for t in range(max(low, start), min(high, start + horizon)):
            values[t - start] = 1.0
    return values


def capacity_profile(
    resources: Resources, name: str, start: int, horizon: int
) -> list[float]:
    """Capacity of binary or multiple resource ``name`` in every unit.

    Raises
    ------
    KeyError
        If ``name`` is neither a binary nor a multiple resource.
    """
    if name in resources.binary:
        spec = (
            resources.binary.get(name)
            if isinstance(resources.binary, dict)
            else None
        )
        windows = None if spec is None else spec.available
        return windows_profile(windows, start, horizon)
    value = resources.multiple[name]
    if isinstance(value, int | float):
        return [float(value)] * horizon
    return step_values(value.steps, start, horizon)


def external_profile(
    resources: Resources, name: str, start: int, horizon: int
) -> list[float]:
    """External net change of consumable ``name`` per unit (> 0 charges).

    0 in every unit for a consumable without ``external`` (and before
    its first step).
    """
    spec = resources.consumable[name]
    external = getattr(spec, "external", ())
    if not external:
        return [0.0] * horizon
    return step_values(external, start, horizon)


def external_before(
    resources: Resources, name: str, start: int, horizon: int
) -> list[float]:
    """The net outside change of consumable ``name`` before each unit:
    entry ``k`` sums the first ``k`` units of :func:`external_profile`
    (``horizon + 1`` entries, the first 0)."""
    return list(
        itertools.accumulate(
            external_profile(resources, name, start, horizon), initial=0.0
        )
    )


def external_charge(
    resources: Resources, name: str, start: int, horizon: int
) -> float:
    """``sum(max(0, r) for r in external_profile(...))``, step by step."""
    spec = resources.consumable[name]
    external = getattr(spec, "external", ())
    end = start + horizon
    total = 0.0
    for k, (since, value) in enumerate(external):
        until = external[k + 1][0] if k + 1 < len(external) else end
        units = min(until, end) - max(since, start)
        if units > 0 and value > 0:
            total += float(value) * units
    return total


def peak_capacity(resources: Resources, name: str) -> float:
    """The largest capacity binary or multiple ``name`` ever has."""
    if name in resources.binary:
        return 1.0
    value = resources.multiple[name]
    if isinstance(value, int | float):
        return float(value)
    return float(max(c for _, c in value.steps))


def changing(resources: Resources) -> tuple[str, ...]:
    """Resources with windows, capacity steps or an external rate."""
    names: list[str] = []
    if isinstance(resources.binary, dict):
        names += [
            name
            for name, spec in resources.binary.items()
            if spec.available is not None
        ]
    names += [
        name
        for name, value in resources.multiple.items()
        if not isinstance(value, int | float)
    ]
    names += [
        name
        for name, spec in resources.consumable.items()
        if getattr(spec, "external", ())
    ]
    return tuple(names)
