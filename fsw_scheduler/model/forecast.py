"""Forecasts of resource profiles, taken into a problem's resources.

A forecast (``telemetry/resources/<name>/forecast``) replaces a resource's
profile from its ``at`` on: windows of a binary resource, capacity steps
of a multiple one, the external rate of a consumable. Before ``at`` the
old profile stays. The rules a forecast must follow are
:func:`fsw_scheduler.model.mission_rules.forecast_issues`. Pure: no
solver, no bus, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec

from .problem import Binary, Capacity, Consumable

if TYPE_CHECKING:
    from collections.abc import Sequence

    from .problem import Resources

__all__ = ["forecast_kind", "with_forecast"]


def forecast_kind(resources: Resources, name: str) -> str | None:
    """The field a forecast of ``name`` carries: ``available`` (binary),
    ``steps`` (multiple) or ``external`` (consumable); None if unknown."""
    if name in resources.binary:
        return "available"
    if name in resources.multiple:
        return "steps"
    if name in resources.consumable:
        return "external"
    return None


def with_forecast(
    resources: Resources,
    name: str,
    at: int,
    values: Sequence[tuple[int, float]],
) -> Resources:
    """``resources`` with ``name``'s profile replaced from ``at`` on.

    Parameters
    ----------
    resources
        The resources of the running problem.
    name
        The resource forecast.
    at
        From this unit on the forecast holds; before it the old profile
        stays.
    values
        The forecast's windows (binary), capacity steps (multiple) or
        external steps (consumable), valid (see
        :func:`fsw_scheduler.model.mission_rules.forecast_issues`).

    Returns
    -------
    Resources
        A copy; the resource becomes the object form it needs.
    """
    kind = forecast_kind(resources, name)
    if kind == "available":
        old = (
            resources.binary.get(name)
            if isinstance(resources.binary, dict)
            else None
        )
        before: list[tuple[int, int]] = (
            [(-(2**31) + 1, at)]
            if old is None or old.available is None
            else [(a, min(b, at)) for a, b in old.available if a < at]
        )
        after = [(max(a, at), int(b)) for a, b in values if b > at]
        merged = tuple(
            (int(a), int(b)) for a, b in _joined(before + after) if a < b
        )
        binary = (
            dict(resources.binary)
            if isinstance(resources.binary, dict)
            else {n: Binary() for n in resources.binary}
        )
        binary[name] = Binary(available=merged)
        return msgspec.structs.replace(resources, binary=binary)
    if kind == "steps":
        old_value = resources.multiple[name]
        old_steps: list[tuple[int, float]] = (
            [(-(2**31) + 1, old_value)]
            if isinstance(old_value, int | float)
            else [(t, float(c)) for t, c in old_value.steps]
        )
        steps = _spliced(old_steps, at, values)
        multiple = dict(resources.multiple)
        multiple[name] = Capacity(
            steps=tuple((int(t), int(c)) for t, c in steps)
        )
        return msgspec.structs.replace(resources, multiple=multiple)
    spec = resources.consumable[name]
    store = (
        Consumable(initial=float(spec))
        if isinstance(spec, int | float)
        else spec
    )
    external = _spliced(list(store.external) or [(at, 0.0)], at, values)
    consumable = dict(resources.consumable)
    consumable[name] = msgspec.structs.replace(
        store, external=tuple((int(t), float(r)) for t, r in external)
    )
    return msgspec.structs.replace(resources, consumable=consumable)


def _spliced(
    old: list[tuple[int, float]],
    at: int,
    new: Sequence[tuple[int, float]],
) -> list[tuple[int, float]]:
    """Steps of ``old`` before ``at``, then ``new`` (from ``at`` on)."""
    kept = [(t, v) for t, v in old if t < at]
    later = [(max(t, at), v) for t, v in new]
    # A forecast's first step may start before ``at``: it holds from
    # ``at``; of steps moved to the same unit the last one holds.
    merged: list[tuple[int, float]] = []
    for t, v in [*kept, *later]:
        if merged and merged[-1][0] == t:
            merged[-1] = (t, v)
        else:
            merged.append((t, v))
    return merged


def _joined(windows: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Sorted windows with touching or overlapping ones joined."""
    out: list[tuple[int, int]] = []
    for a, b in sorted(windows):
        if out and a <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out
