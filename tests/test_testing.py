"""Tests of the pytest fixtures :mod:`fsw_scheduler.testing` ships."""

from __future__ import annotations

from typing import TYPE_CHECKING

import pytest

from .factories import make_doc, make_task

if TYPE_CHECKING:
    from fsw_scheduler.testing import SchedulerHarness

pytest_plugins = ["fsw_scheduler.testing"]


@pytest.fixture
def scheduler_problem() -> dict:
    """A problem given as a dict, as the API takes them."""
    return make_doc(
        [make_task("Only", 2, uses={"power": 5})],
        10,
        resources={"multiple": {"power": 10}},
    )


def test_a_problem_fixture_may_return_a_dict(
    scheduler_harness: SchedulerHarness,
) -> None:
    """Tests that overriding ``scheduler_problem`` with a dict works: the
    harness plans it (it raised a TypeError)."""
    scheduler_harness.tick(0)
    plan = scheduler_harness.wait_plan()
    assert [a.task for a in plan.activities] == ["Only"]
