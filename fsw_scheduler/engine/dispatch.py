"""The dispatch lifecycle: where each activity stands between plan and report.

An activity goes ``planned -> dispatched -> running -> completed |
failed``, or ``preempted`` / ``obsolete`` when a replan takes it away.
A command given is a fact: a replan that takes a commanded activity away
(moves it, or removes it) never sends it again under another id; it sends
a *cancel* of the dispatch that stands (``action: cancel``, the same
``dispatch_id``), and the activity is ``cancelling`` until the executor
answers ``cancelled`` (then it may be commanded again where the plan now
puts it) or reports it ``completed`` / ``failed``. With no answer within
``cancel_timeout`` units it is ``unknown``: never commanded again, taken
as having run.
:class:`Dispatches` keeps that map and the bookkeeping around it (when each
dispatch was sent, which one still stands, what the last status said);
the :class:`~fsw_scheduler.engine.Engine` decides *when* each step
happens. Kept apart so that the rules of the lifecycle (a dispatch that a
replan leaves in place is not sent again; a dispatch with no report in
time counts as failed) sit in one place.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

from ..wire import topics
from ..wire.messages import Dispatch
from .events import Publish

if TYPE_CHECKING:
    from collections.abc import Collection, Iterable

    from ..model.change import Removal
    from ..model.plan import Activity, Plan
    from ..model.problem import Problem
    from .snapshot import Lifecycle

#: The states in which an activity is still to be flown (or stopped).
LIVE = ("planned", "dispatched", "running", "cancelling")
#: The states of a command that stands: given, and not answered for good.
COMMANDED = ("dispatched", "running")
#: States that say an activity was commanded (a dispatch was sent).
WAS_COMMANDED = (
    "dispatched",
    "running",
    "cancelling",
    "completed",
    "failed",
    "unknown",
)


class Dispatches:
    """The lifecycle map of every known activity, with its bookkeeping.

    Parameters
    ----------
    lifecycle
        Task to its state.
    dispatched
        Task to the time unit its standing dispatch was sent (until a
        report arrives).
    sent
        Task to the ``(start, end)`` of its dispatch still standing.
    reported
        The lifecycle as the last published status gave it: statuses
        carry the difference.
    cancelling
        Task to the time unit the cancel of its dispatch (still in
        ``sent``) was sent, until the executor answers it.
    numbers
        Task to the number of its last run command (1 for the first):
        part of the ``dispatch_id`` from the second on
        (:func:`dispatch_id`), so that a task commanded again at the same
        span (after a cancel answered, or a failure in the unit it was
        sent) gets an id no receiver has acted on. Absent: 1.
    """

    __slots__ = (
        "cancelling",
        "dispatched",
        "lifecycle",
        "numbers",
        "reported",
        "sent",
    )

    def __init__(
        self,
        lifecycle: dict[str, Lifecycle] | None = None,
        dispatched: dict[str, int] | None = None,
        sent: dict[str, tuple[int, int]] | None = None,
        reported: dict[str, Lifecycle] | None = None,
        cancelling: dict[str, int] | None = None,
        numbers: dict[str, int] | None = None,
    ) -> None:
        self.lifecycle = dict(lifecycle or {})
        self.dispatched = dict(dispatched or {})
        self.sent = dict(sent or {})
        self.reported = dict(reported or {})
        self.cancelling = dict(cancelling or {})
        self.numbers = dict(numbers or {})

    def id_of(self, task: str) -> str | None:
        """The ``dispatch_id`` of ``task``'s dispatch that stands (None
        without one)."""
        span = self.sent.get(task)
        if span is None:
            return None
        return span_id(task, span, self.number(task))

    def number(self, task: str) -> int:
        """The number of ``task``'s last run command (1 when none is
        recorded: the first, or a state from before numbers were kept)."""
        return self.numbers.get(task, 1)

    def adopt(
        self,
        plan: Plan,
        continuing: Iterable[str],
        removed: Iterable[Removal],
        max_history: int,
        now: int | None = None,
        readded: Iterable[str] = (),
    ) -> list[tuple[str, tuple[int, int]]]:
        """Take a new plan: removed tasks leave, planned ones wait again.

        A command that the new plan leaves exactly in place stands and is
        not sent again (sending it again with each replan made storms),
        whether or not its ``running`` report came during the solve.
        A commanded activity the plan moves or removes is cancelled, not
        commanded again (when ``now`` is given; without it, as journals
        recorded before cancels, it is planned again): it turns
        ``cancelling`` and is returned, with the span of the dispatch to
        cancel. A completed activity is not commanded again, unless the
        rules brought it back to run again (``readded``: a tight chain).
        At most ``max_history`` finished entries are kept (oldest go).
        """
        keep = set(continuing)
        again = set(readded)
        cancels: list[tuple[str, tuple[int, int]]] = []

        def cancel(task: str) -> bool:
            span = self.sent.get(task)
            if (
                now is None
                or task in keep
                or span is None
                or self.lifecycle.get(task) not in COMMANDED
            ):
                return False
            self.lifecycle[task] = "cancelling"
            self.cancelling[task] = now
            self.dispatched.pop(task, None)
            cancels.append((task, span))
            return True

        for removal in removed:
            if removal.rule == "finished" or cancel(removal.task):
                continue
            if removal.rule in ("obsolete", "tight_cascade"):
                self.lifecycle[removal.task] = "obsolete"
            else:
                self.lifecycle.setdefault(removal.task, "preempted")
                if self.lifecycle[removal.task] in COMMANDED:
                    self.lifecycle[removal.task] = "preempted"
        for activity in plan.activities:
            if activity.task in keep:
                continue
            state = self.lifecycle.get(activity.task)
            if state in ("cancelling", "unknown") or (
                now is not None
                and state == "completed"
                and activity.task not in again
            ):
                # Waits for its answer, or already ran (a plan computed
                # before its report): never commanded again blindly.
                continue
            if state in COMMANDED and self.sent.get(activity.task) == (
                activity.start,
                activity.end,
            ):
                # Reported running while the solve ran, and kept where it
                # was commanded: a cancel here would stop it for nothing.
                continue
            if cancel(activity.task):
                continue
            self.lifecycle[activity.task] = "planned"
            self.dispatched.pop(activity.task, None)
            self.sent.pop(activity.task, None)
        self._forget_history(max_history)
        return cancels

    def due(
        self,
        plan: Plan,
        continuing: Iterable[str],
        now: int,
        before: int | None = None,
        held: Collection[str] = (),
    ) -> tuple[list[Activity], list[Activity]]:
        """Mark dispatched, and return, each planned activity due by now.

        An activity whose start a clock jump passed over (after
        ``before``, the time of the previous step, and before ``now``) is
        not dispatched: flown now, it would run out of its time. It is
        marked ``missed`` and returned apart, ``(due, missed)``. A late
        plan's activities are dispatched late (their time passed during
        the solve, not in a jump). ``held`` activities wait: neither
        dispatched nor missed (:mod:`.overrun`).
        """
        keep = set(continuing)
        due = []
        missed = []
        for activity in plan.activities:
            if activity.start > now:
                break  # activities are sorted by start
            if (
                activity.task in keep
                or self.lifecycle.get(activity.task) != "planned"
                or activity.task in held
            ):
                continue
            if before is not None and before < activity.start < now:
                self.lifecycle[activity.task] = "missed"
                missed.append(activity)
                continue
            self.numbers[activity.task] = self._last_number(activity.task) + 1
            self.lifecycle[activity.task] = "dispatched"
            self.dispatched[activity.task] = now
            self.sent[activity.task] = (activity.start, activity.end)
            due.append(activity)
        return due, missed

    def _last_number(self, task: str) -> int:
        """The number of ``task``'s last run command (0: none). A state
        from before numbers were kept counts a commanded task as 1."""
        if task in self.numbers:
            return self.numbers[task]
        ran = self.lifecycle.get(task) in (*WAS_COMMANDED, "preempted")
        return 1 if ran or task in self.sent else 0

    def standing(self, plan: Plan) -> list[tuple[Activity, int]]:
        """Each activity whose dispatch still stands, with when it was sent."""
        out = []
        for activity in plan.activities:
            task = activity.task
            if self.lifecycle.get(task) != "dispatched" or self.sent.get(
                task
            ) != (activity.start, activity.end):
                continue
            out.append((activity, self.dispatched.get(task, activity.start)))
        return out

    def report(self, task: str, state: Lifecycle) -> None:
        """A report on ``task``: its dispatch no longer waits for one.

        What was sent stays while the activity runs: its reports answer
        that dispatch, though a replan re-bases the activity to start now.
        A ``running`` report on a dispatch being cancelled leaves it
        ``cancelling``: only an answer ends that.
        """
        self.dispatched.pop(task, None)
        if state == "running" and task in self.cancelling:
            return
        self.cancelling.pop(task, None)
        if state not in LIVE:
            self.sent.pop(task, None)
        self.lifecycle[task] = state

    def note(self, task: str, state: Lifecycle) -> None:
        """Record a state without touching the dispatch bookkeeping."""
        self.lifecycle[task] = state

    def timed_out(self, now: int, timeout: int) -> list[tuple[str, int]]:
        """Dispatches with no report for more than ``timeout`` units.

        Each is marked ``failed`` and returned with its dispatch time,
        oldest task name first.
        """
        late = []
        for task, since in sorted(self.dispatched.items()):
            if now - since > timeout:
                del self.dispatched[task]
                self.sent.pop(task, None)
                self.lifecycle[task] = "failed"
                late.append((task, since))
        return late

    def cancel_overdue(self, now: int, timeout: int) -> list[str]:
        """Cancels with no answer for more than ``timeout`` units.

        Each activity turns ``unknown`` (it may have run: it is never
        commanded again) and is returned, oldest task name first.
        """
        late = []
        for task, since in sorted(self.cancelling.items()):
            if now - since > timeout:
                del self.cancelling[task]
                self.sent.pop(task, None)
                self.lifecycle[task] = "unknown"
                late.append(task)
        return late

    def changed(self) -> dict[str, Lifecycle]:
        """Entries changed since the last call: what a status carries."""
        changed = {
            k: v
            for k, v in sorted(self.lifecycle.items())
            if self.reported.get(k) != v
        }
        self.reported = dict(self.lifecycle)
        return changed

    def _forget_history(self, max_history: int) -> None:
        finished = [
            task for task, state in self.lifecycle.items() if state not in LIVE
        ]
        excess = max(0, len(finished) - max_history)
        for task in finished[:excess]:
            del self.lifecycle[task]
            self.reported.pop(task, None)
            self.sent.pop(task, None)
            self.cancelling.pop(task, None)
            self.numbers.pop(task, None)


def dispatch_id(activity: Activity, number: int = 1) -> str:
    """The name of the command that flies ``activity``:
    ``<task>:<start>-<end>``, the same for as long as it keeps its place;
    from the task's second run command on, ``#<number>`` follows (a
    command at a span already commanded, after a cancel or a failure,
    is a new command)."""
    return span_id(activity.task, (activity.start, activity.end), number)


def span_id(task: str, span: tuple[int, int], number: int = 1) -> str:
    """:func:`dispatch_id` of ``task``'s command number ``number`` for
    ``span``."""
    base = f"{task}:{span[0]}-{span[1]}"
    return base if number <= 1 else f"{base}#{number}"


def parse_id(dispatch_id: str) -> tuple[str, tuple[int, int], int] | None:
    """Task, span and number of a ``dispatch_id`` (None if it is not
    one of :func:`dispatch_id`'s)."""
    head, _, tail = dispatch_id.rpartition(":")
    span_text, mark, number_text = tail.partition("#")
    start, _, end = span_text.partition("-")
    if not (head and start.isdigit() and end.isdigit()):
        return None
    if mark and not (number_text.isdigit() and int(number_text) > 1):
        return None
    return head, (int(start), int(end)), int(number_text or 1)


def dispatch_message(
    plan_id: int,
    problem: Problem,
    activity: Activity,
    dispatched_at: int,
    term: int = 0,
    action: Literal["run", "cancel"] = "run",
    number: int = 1,
) -> Publish:
    """The dispatch of ``activity``, sent at ``dispatched_at``.

    Its ``dispatch_id`` (task, start and end, and ``number`` from the
    task's second command on) stays the same for as long as the command
    stands, so a receiver keeps one. With
    ``action`` ``cancel``, the same message tells the receiver to stop (or
    never start) that dispatch and answer ``cancelled``; on the same key
    as the dispatch, so it cannot overtake it.
    """
    task = activity.task
    return Publish(
        f"{topics.DISPATCH}/{task}",
        Dispatch(
            task=task,
            plan_id=plan_id,
            start=activity.start,
            end=activity.end,
            uses=dict(sorted(problem.task(task).uses.items())),
            dispatched_at=dispatched_at,
            late=activity.start < dispatched_at,
            dispatch_id=dispatch_id(activity, number),
            term=term,
            action=action,
        ),
    )
