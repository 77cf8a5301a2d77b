"""Tests of the demo scenarios (fsw_scheduler.app.demo)."""

from __future__ import annotations

import io
from typing import TYPE_CHECKING

from fsw_scheduler.app.demo import orbit_scenario, run_demo

if TYPE_CHECKING:
    from pathlib import Path


def test_the_orbit_scenario_replans_for_the_forecast_only(
    tmp_path: Path,
) -> None:
    """Tests ``fsw-scheduler demo --scenario orbit``: the simulated
    spacecraft charges and drains as the orbit does (so no level drift
    replans), the forecast of a longer eclipse gives the one replan, T3
    switches to LF out of the eclipse, and the journal replays
    IDENTICAL."""
    stream = io.StringIO()
    result = run_demo(
        tmp_path, scenario=orbit_scenario(), pictures=False, stream=stream
    )
    assert [(p.plan_id, p.trigger) for p in result.plans] == [
        (1, "initial"),
        (2, "forecast"),
    ]
    executed = {a.task for a in result.executed}
    assert {"T3-LF", "T4-HF"} <= executed
    assert "T3-HF" not in executed
    assert result.verified is True
    assert "forecast  power from t=100" in stream.getvalue()
