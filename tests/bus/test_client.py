"""Tests of the receiver's rules as :class:`Fence` applies them."""

from __future__ import annotations

from typing import Literal

from fsw_scheduler.testing import Fence
from fsw_scheduler.wire import messages


def _dispatch(
    dispatch_id: str,
    term: int = 1,
    action: Literal["run", "cancel"] = "run",
) -> messages.Dispatch:
    task, span = dispatch_id.split(":")
    start, end = (int(x) for x in span.split("-"))
    return messages.Dispatch(
        task=task,
        plan_id=1,
        start=start,
        end=end,
        uses={},
        dispatch_id=dispatch_id,
        term=term,
        action=action,
    )


def test_a_dispatch_is_acted_on_once_and_a_cancel_always_answered() -> None:
    """Tests that a run is carried out once per id, a cancel of it is
    never taken for a run, and is obeyed (answered) each time it comes."""
    fence = Fence()
    assert fence.execute(_dispatch("X:0-4"))
    assert not fence.execute(_dispatch("X:0-4"))
    cancel = _dispatch("X:0-4", action="cancel")
    assert not fence.execute(cancel)
    assert fence.cancel(cancel)
    assert fence.cancel(cancel)
    assert not fence.execute(_dispatch("X:0-4"))
    assert fence.execute(_dispatch("X:5-9"))


def test_a_cancel_before_its_dispatch_keeps_it_from_starting() -> None:
    """Tests that a dispatch whose cancel came first is never started."""
    fence = Fence()
    assert fence.cancel(_dispatch("X:0-4", action="cancel"))
    assert not fence.execute(_dispatch("X:0-4"))


def test_a_stale_term_neither_runs_nor_cancels() -> None:
    """Tests that a run or a cancel from a term below the highest seen
    is ignored and counted as fenced."""
    fence = Fence()
    assert fence.admit(messages.Term(term=3))
    assert not fence.execute(_dispatch("X:0-4", term=2))
    assert not fence.cancel(_dispatch("Y:0-4", term=2, action="cancel"))
    assert fence.fenced == 2


def test_a_blind_dispatch_of_a_task_run_in_a_lower_term_is_not_run() -> None:
    """Tests that a dispatch from a higher term of a task last run under
    a lower term (no cancel since) is not run: the earlier run is named,
    once per task and term, and a later dispatch of that term runs."""
    fence = Fence()
    assert fence.execute(_dispatch("X:6-8", term=1))
    assert fence.earlier_run(_dispatch("X:9-11", term=2)) == "X:6-8"
    assert not fence.execute(_dispatch("X:9-11", term=2))
    assert fence.earlier_run(_dispatch("X:12-14", term=2)) is None
    assert fence.execute(_dispatch("X:12-14", term=2))


def test_a_task_cancelled_in_a_lower_term_may_run_again() -> None:
    """Tests that a task whose earlier run was cancelled is run again when
    a new commander dispatches it."""
    fence = Fence()
    assert fence.execute(_dispatch("X:6-8", term=1))
    assert fence.cancel(_dispatch("X:6-8", term=1, action="cancel"))
    assert fence.earlier_run(_dispatch("X:9-11", term=2)) is None
    assert fence.execute(_dispatch("X:9-11", term=2))
