"""Tests of forecasts taken into a problem's resources
(fsw_scheduler.model.forecast) and of their rules."""

from __future__ import annotations

from typing import TYPE_CHECKING

from fsw_scheduler.model.forecast import with_forecast
from fsw_scheduler.model.mission_rules import forecast_issues

from ..factories import make_doc, make_task, problem_from

if TYPE_CHECKING:
    from collections.abc import Sequence

    from fsw_scheduler.model.problem import Resources


def _resources() -> Resources:
    return problem_from(
        make_doc(
            [make_task("a")],
            horizon=40,
            resources={
                "binary": ["cam"],
                "multiple": {"power": 5},
                "consumable": {"battery": 3},
            },
        )
    ).resources


def test_a_forecast_replaces_the_profile_from_at_on() -> None:
    """Tests each kind: before ``at`` the old profile stays (a constant
    becomes a first step, a list-written binary resource an object), from
    ``at`` on the forecast's holds."""
    resources = _resources()
    windows = with_forecast(resources, "cam", 10, [(5, 12), (20, 30)])
    assert windows.capacity_profile("cam", 0, 40) == [
        1.0 if t < 12 or 20 <= t < 30 else 0.0 for t in range(40)
    ]
    steps = with_forecast(resources, "power", 10, [(10, 2), (25, 4)])
    assert steps.capacity_profile("power", 0, 40) == [
        5.0 if t < 10 else 2.0 if t < 25 else 4.0 for t in range(40)
    ]
    again = with_forecast(steps, "power", 20, [(20, 1)])
    assert again.capacity_profile("power", 0, 40)[18:22] == [2, 2, 1, 1]
    sun = with_forecast(resources, "battery", 8, [(8, 1.5), (30, 0)])
    assert sun.external_profile("battery", 0, 40)[6:10] == [0, 0, 1.5, 1.5]
    assert sun.initial("battery") == 3
    assert set(sun.changing) == {"battery"}


def test_forecast_rules() -> None:
    """Tests the rules of a forecast, each at its path."""
    resources = _resources()

    def paths(
        name: str, at: int, **fields: Sequence[tuple[int, float]] | None
    ) -> list[str]:
        given: dict[str, Sequence[tuple[int, float]] | None] = {
            "available": None,
            "steps": None,
            "external": None,
        }
        given.update(fields)
        found = forecast_issues(resources, name, at, given)
        return [issue.path for issue in found]

    assert paths("cam", 3, available=[(3, 9)]) == []
    assert paths("cam", 3) == ["available"]
    assert paths("power", 3, steps=[(4, 1)]) == ["steps[0][0]"]
    assert paths("power", 3, steps=[(3, 1.5)]) == ["steps[0][1]"]
    assert paths("battery", 3, external=[(3, 1), (3, 2)]) == ["external[1][0]"]
    assert paths("battery", 3, steps=[(3, 1)]) == ["steps", "external"]
    assert paths("sun", 3, external=[(3, 1)]) == ["resource"]
