"""A short run of tools/soak: a flood against the real node loses nothing."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..factories import tool_script

if TYPE_CHECKING:
    from pathlib import Path


def test_short_soak_loses_nothing() -> None:
    """Tests that every flooded goal gets a verdict and the node lives."""
    soak = tool_script("soak", "fsw_soak")
    figures = soak.run_soak(
        goals=60,
        fuzz=40,
        telemetry=600,
        settle_s=60.0,
        node_args=("--time-limit", "2", "--response-deadline", "4"),
        log=lambda _text: None,
    )
    assert figures.lost == []
    assert figures.accepted + figures.rejected == 100
    assert figures.accepted > 0
    assert figures.telemetry_lost == 0
    assert (
        figures.telemetry_processed + figures.telemetry_superseded
        == figures.telemetry_sent
    )
    assert figures.loop_alive and figures.token_up
    # Every fuzzed payload was named in its rejection.
    assert figures.unnamed_rejections == 0
    table = soak.table(figures)
    assert "| lost (no verdict)" in table


def test_reports_racing_the_clock_execute_nothing_twice(
    tmp_path: Path,
) -> None:
    """Tests that with a slow executor whose reports race the clock and
    goals competing for the running plan's camera just before ticks, a
    README receiver executes nothing twice, no accepted goal is lost,
    every goal has one verdict and no report is rejected "after now"."""
    race = tool_script("soak_race", "fsw_soak_race")
    figures = race.run_race(
        tmp_path,
        units=16,
        unit_s=0.2,
        seed=3,
        log=lambda _text: None,
        settle=10,
    )
    assert figures.goals == 8
    assert figures.raced > 0  # reports did race the clock
    assert figures.executed_twice == []
    assert figures.unfinished == []
    assert figures.lost == []
    assert figures.no_verdict == [] and figures.two_verdicts == []
    assert figures.after_now == 0
    assert figures.journals == 1 and figures.not_identical == []
