"""Tests of the bus keys (fsw_scheduler.wire.topics)."""

from __future__ import annotations

from fsw_scheduler.wire.topics import Topics, input_kind, kind_of


def test_the_forecast_key_is_an_input_of_its_own() -> None:
    """Tests that ``telemetry/resources/<name>/forecast`` is a forecast
    input, apart from the level on ``telemetry/resources/<name>``."""
    topics = Topics()
    key = topics.resource_forecast("power")
    assert key == "fsw/sat1/telemetry/resources/power/forecast"
    assert input_kind(topics, key, "bus") == "resource_forecast"
    assert kind_of("telemetry/resources/power") == "resource_level"
    assert kind_of("telemetry/resources/power/other") is None
    assert kind_of("telemetry/resources//forecast") is None
