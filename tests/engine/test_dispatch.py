"""Tests of the dispatch lifecycle: a command given is a fact, preemption
is a cancel on the bus, and an activity is commanded again only after
the cancel is answered."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.engine.config import EngineConfig
from fsw_scheduler.engine.dispatch import parse_id, span_id
from fsw_scheduler.engine.events import ReportArrived
from fsw_scheduler.model.problem import decode_problem
from fsw_scheduler.wire import messages

from ..factories import make_doc, make_task
from .driver import Driver, published, statuses

if TYPE_CHECKING:
    from .driver import ReportState

CAMERA = {"binary": ["camera"], "multiple": {"power": 100}}
#: A node's problem: resources and horizon; goals bring the tasks.
EMPTY = decode_problem(json.dumps(make_doc([], 30, CAMERA)), allow_empty=True)
#: The node's defaults: reports one unit ahead held, cancels answered
#: within three units.
FACTS = EngineConfig(report_ahead=1, cancel_timeout=3)


def _commands(driver: Driver) -> list[tuple[str, str]]:
    """``(action, dispatch_id)`` of every dispatch published so far."""
    return [
        (d.action, d.dispatch_id)
        for d in published(driver.history, messages.Dispatch)
    ]


def _runs(driver: Driver, task: str = "X") -> list[str]:
    """The ids of every ``run`` dispatch of ``task`` so far."""
    return [
        i
        for a, i in _commands(driver)
        if a == "run" and i.startswith(f"{task}:")
    ]


def _report(
    driver: Driver,
    task: str,
    state: ReportState,
    at: int,
    dispatch_id: str,
) -> None:
    driver.step(
        ReportArrived(
            messages.ActivityReport(
                task,
                state,
                at,
                dispatch_id=dispatch_id,
            )
        )
    )


def _preempted(config: EngineConfig = FACTS) -> Driver:
    """X (4 units, preemption ``from_start``) runs on the camera from 0;
    at 1 a goal's mandatory Y needs the camera at 1 or 2: the paper's
    rules preempt X and plan it again after Y."""
    driver = Driver(EMPTY, config)
    driver.tick(0)
    driver.goal(
        {
            "goal_id": "g1",
            "tasks": [
                make_task(
                    "X",
                    4,
                    preemption="from_start",
                    feasible_interval=[0, 20],
                    uses={"camera": 1},
                )
            ],
        }
    )
    assert _commands(driver) == [("run", "X:0-4")]
    _report(driver, "X", "running", 0, "X:0-4")
    driver.tick(1)
    driver.goal(
        {
            "goal_id": "g2",
            "tasks": [
                make_task(
                    "Y",
                    1,
                    delay_cost=5,
                    schedule_cost=0,
                    feasible_interval=[1, 2],
                    feasible_interval_applies_to="start",
                    uses={"camera": 1},
                )
            ],
        }
    )
    return driver


def test_a_preempted_command_is_cancelled_before_it_is_sent_again() -> None:
    """Tests that the paper's preemption of a running activity is a cancel
    of its dispatch (same id), that the activity is not commanded again
    before the executor answers ``cancelled``, and is then, under a new
    id, where the plan puts it."""
    driver = _preempted()
    x = next(a for a in driver.plan.activities if a.task == "X")
    assert x.start > 1
    assert ("cancel", "X:0-4") in _commands(driver)
    assert driver.engine.status().activities["X"] == "cancelling"
    driver.tick(x.start)  # its new place comes: still no answer
    assert _runs(driver) == ["X:0-4"]
    _report(driver, "X", "cancelled", x.start, "X:0-4")
    assert _runs(driver) == ["X:0-4", f"X:{x.start}-{x.end}#2"]


def test_a_cancel_answered_late_replans_the_activity() -> None:
    """Tests that a cancel answered after the activity's new place began
    replans it (``missed``), and commands it once more, not twice."""
    driver = _preempted()
    x = next(a for a in driver.plan.activities if a.task == "X")
    for now in range(2, x.start + 2):
        driver.tick(now)
    _report(driver, "X", "cancelled", x.start + 1, "X:0-4")
    for now in range(x.start + 2, 20):
        driver.tick(now)
    runs = _runs(driver)
    assert len(runs) == 2
    assert runs[0] == "X:0-4"
    assert int(runs[1].split(":")[1].split("-")[0]) >= x.start + 1


def test_a_cancel_never_answered_leaves_the_activity_unknown() -> None:
    """Tests that with no answer to a cancel within ``cancel_timeout``
    units the activity turns ``unknown``, is said so, and is never
    commanded again."""
    driver = _preempted()
    out = []
    for now in range(2, 12):
        out += driver.tick(now)
    assert statuses(out, "activity_unknown")
    assert driver.engine.status().activities["X"] == "unknown"
    assert _runs(driver) == ["X:0-4"]


def test_a_completion_racing_the_cancel_is_a_fact() -> None:
    """Tests that an activity that completes before its cancel reaches
    the executor is completed, and never commanded again."""
    driver = _preempted()
    _report(driver, "X", "completed", 1, "X:0-4")
    for now in range(2, 12):
        driver.tick(now)
    assert driver.engine.status().activities["X"] == "completed"
    assert _runs(driver) == ["X:0-4"]


def test_a_cancel_stands_across_a_resume() -> None:
    """Tests that a cancel waiting for its answer is in the snapshot and
    sent again, with its id, by an engine rebuilt from it."""
    driver = _preempted()
    rebuilt = type(driver.engine).restore(FACTS, driver.engine.snapshot())
    again = published(rebuilt.resume_commands(), messages.Dispatch)
    assert ("cancel", "X:0-4") in [(d.action, d.dispatch_id) for d in again]
    assert rebuilt.status().activities["X"] == "cancelling"


def test_recorded_sessions_keep_moving_commands_without_a_cancel() -> None:
    """Tests that without ``cancel_timeout`` (journals recorded before
    cancels) the preempted activity is planned again and no cancel is
    sent, as those journals recorded."""
    driver = _preempted(EngineConfig())
    assert all(a == "run" for a, _ in _commands(driver))


def _camera_goal(
    driver: Driver, length: int, preemption: str, window: list[int]
) -> None:
    """Goal g1: task X of ``length`` on the camera within ``window``."""
    task = make_task(
        "X",
        length,
        preemption=preemption,
        feasible_interval=window,
        uses={"camera": 1},
    )
    driver.goal({"goal_id": "g1", "tasks": [task]})


@pytest.mark.parametrize("preemption", ["none", "from_start", "delete"])
@pytest.mark.parametrize("running_first", [True, False])
def test_a_command_reported_running_during_a_solve_stands(
    preemption: str, running_first: bool
) -> None:
    """Tests that an activity dispatched while a solve runs, and reported
    ``running`` before or after that solve returns with it in the same
    place, is neither cancelled nor commanded again (a cancel there
    stopped it for nothing, and its next command reused its id)."""
    driver = Driver(EMPTY, FACTS, hold=True)
    driver.tick(0)
    _camera_goal(driver, 4, preemption, [2, 20])
    driver.finish()
    driver.tick(1)
    driver.goal(
        {
            "goal_id": "g2",
            "tasks": [
                make_task("Y", 1, feasible_interval=[2, 20], uses={"power": 5})
            ],
        }
    )
    driver.tick(2)  # X is dispatched while g2's solve is held
    assert _runs(driver) == ["X:2-6"]
    if running_first:
        _report(driver, "X", "running", 2, "X:2-6")
    while driver.held:
        driver.finish()
    if not running_first:
        _report(driver, "X", "running", 2, "X:2-6")
    for now in range(3, 6):
        driver.tick(now)
    assert [c for c in _commands(driver) if c[1].startswith("X:")] == [
        ("run", "X:2-6")
    ]
    assert driver.engine.status().activities["X"] == "running"
    _report(driver, "X", "completed", 6, "X:2-6")
    driver.tick(6)
    assert driver.engine.status().activities["X"] == "completed"


@pytest.mark.parametrize(
    "preemption", ["none", "from_start", "from_interrupt"]
)
def test_a_retry_at_the_same_span_is_a_new_command(preemption: str) -> None:
    """Tests that an activity that fails in the unit it was sent, and is
    planned again at the same span, is commanded under a new id (a
    receiver ignores an id it has acted on: with the old id the retry
    never ran and the activity stayed ``dispatched``); its reports are
    taken, and an engine rebuilt from the snapshot sends the same id."""
    driver = Driver(EMPTY, FACTS)
    driver.tick(0)
    _camera_goal(driver, 2, preemption, [0, 20])
    _report(driver, "X", "running", 0, "X:0-2")
    _report(driver, "X", "failed", 0, "X:0-2")
    assert _runs(driver) == ["X:0-2", "X:0-2#2"]
    rebuilt = type(driver.engine).restore(FACTS, driver.engine.snapshot())
    again = published(rebuilt.resume_commands(), messages.Dispatch)
    assert [(d.action, d.dispatch_id) for d in again] == [("run", "X:0-2#2")]
    _report(driver, "X", "running", 0, "X:0-2#2")
    driver.tick(1)
    driver.tick(2)
    _report(driver, "X", "completed", 2, "X:0-2#2")
    assert driver.engine.status().activities["X"] == "completed"
    assert _runs(driver) == ["X:0-2", "X:0-2#2"]


def test_dispatch_ids_name_span_and_number() -> None:
    """Tests that ids read back as they were written, and that what is
    not one is refused."""
    assert span_id("A:b", (3, 7)) == "A:b:3-7"
    assert span_id("A:b", (3, 7), 4) == "A:b:3-7#4"
    assert parse_id("A:b:3-7#4") == ("A:b", (3, 7), 4)
    assert parse_id("A:b:3-7") == ("A:b", (3, 7), 1)
    for bad in ("A:3-7#1", "A:3-7#x", "A:3-", "3-7", "A:3-7#"):
        assert parse_id(bad) is None, bad
