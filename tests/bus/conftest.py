"""Fixtures of the bus tests: a harness node that has started."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from collections.abc import Iterator

    from fsw_scheduler.testing import SchedulerHarness


@pytest.fixture
def started(
    scheduler_harness: SchedulerHarness,
) -> Iterator[SchedulerHarness]:
    """A harness whose node has adopted its initial plan at t=0."""
    scheduler_harness.tick(0)
    scheduler_harness.wait_plan(lambda p: p.plan_id == 1)
    yield scheduler_harness
