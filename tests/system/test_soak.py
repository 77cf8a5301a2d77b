"""A short run of tools/soak: a flood against the real node loses nothing."""

from __future__ import annotations

from ..factories import tool_script


def test_short_soak_loses_nothing() -> None:
    """Tests that every flooded goal gets a verdict and the node lives."""
    soak = tool_script("soak", "fsw_soak")
    figures = soak.run_soak(  # type: ignore[attr-defined]
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
    table = soak.table(figures)  # type: ignore[attr-defined]
    assert "| lost (no verdict)" in table
