"""What a receiver of scheduler outputs does: the fence (README,
"Receiving dispatches"; docs/redundancy.md, "What a receiver must do").

Pure bookkeeping over decoded messages, usable by any executor: it keeps
the highest term, acts on a dispatch once, obeys cancels and answers a
blind command with the earlier run.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..wire.terms import term_refused

if TYPE_CHECKING:
    from ..wire import messages

__all__ = ["Fence"]


class Fence:
    """What a receiver of scheduler outputs does, so that a stale
    commander can never make it act and no command runs twice (README,
    "Receiving dispatches"; docs/redundancy.md, "What a receiver must
    do").

    * Keep the highest ``term`` seen on any plan, dispatch, status or
      ``scheduler/term`` message; ignore anything with a lower one.
    * Act on a dispatch (``action`` ``run``) once per ``dispatch_id``; a
      repeat (a resumed or new commander sends the same command again) is
      not a new command, and neither is a dispatch already cancelled.
    * A dispatch of a task last run under a lower term, with no cancel
      since, is not run: the last report on that run is sent again
      (:meth:`earlier_run`).
    * Obey a cancel (``action`` ``cancel``): stop that dispatch if it
      runs, never start it if it has not, and answer with a report
      ``cancelled`` echoing its ``dispatch_id``, each time a cancel comes
      (if it had already ended, its ``completed`` or ``failed`` report
      answers).
    * Never believe a term outside ``0..2**63-1`` or more than
      :data:`~fsw_scheduler.wire.terms.MAX_TERM_JUMP` above the highest
      seen: on an open bus anyone can write one, and raising the fence to
      it would silence every genuine commander (counted in ``refused``).
    """

    def __init__(self) -> None:
        self.term = 0
        self.acted: set[str] = set()
        self.cancelled: set[str] = set()
        self.fenced = 0
        #: Task to the ``(dispatch_id, term)`` of the last run acted on.
        self.last: dict[str, tuple[str, int]] = {}
        #: ``(task, term)`` told of an earlier run (:meth:`earlier_run`).
        self.told: set[tuple[str, int]] = set()
        self.refused = 0

    def admit(self, message: object) -> bool:
        """Whether ``message`` comes from a current term (raising it)."""
        term = getattr(message, "term", 0)
        if term_refused(term, self.term) is not None:
            self.refused += 1
            return False
        if term < self.term:
            self.fenced += 1
            return False
        self.term = term
        return True

    def execute(self, dispatch: messages.Dispatch) -> bool:
        """Whether to carry ``dispatch`` out now (a run, the first time,
        not stale, not cancelled)."""
        if dispatch.action == "cancel" or not self.admit(dispatch):
            return False
        key = _command_id(dispatch)
        if key in self.acted or key in self.cancelled:
            return False
        self.acted.add(key)
        self.last[dispatch.task] = (key, dispatch.term)
        return True

    def earlier_run(self, dispatch: messages.Dispatch) -> str | None:
        """The ``dispatch_id`` of an earlier run of the task to report
        again instead of carrying ``dispatch`` out, or None.

        A commander that took over from an older state may command, blind,
        a task its predecessor (a lower term) commanded last and the
        receiver ran, with no cancel since: the receiver does not run it
        again, it sends its last report on the earlier run (that run's
        ``dispatch_id`` and ``term``), once per task and term; the new
        commander takes it as a fact. ``dispatch`` then counts as acted on.
        """
        if dispatch.action == "cancel" or dispatch.term < self.term:
            return None
        key = _command_id(dispatch)
        earlier = self.last.get(dispatch.task)
        if (
            key in self.acted
            or earlier is None
            or earlier[1] >= dispatch.term
            or earlier[0] in self.cancelled
            or (dispatch.task, dispatch.term) in self.told
        ):
            return None
        self.admit(dispatch)
        self.acted.add(key)
        self.told.add((dispatch.task, dispatch.term))
        return earlier[0]

    def cancel(self, dispatch: messages.Dispatch) -> bool:
        """Whether ``dispatch`` is a cancel to obey now (not stale): stop
        or never start the dispatch it names, and answer ``cancelled``,
        every time one comes (a new commander may ask again; a repeated
        answer is harmless)."""
        if dispatch.action != "cancel" or not self.admit(dispatch):
            return False
        self.cancelled.add(_command_id(dispatch))
        return True


def _command_id(dispatch: messages.Dispatch) -> str:
    """The id a receiver acts on once (``dispatch_id``, or for a
    scheduler too old to send one, the task and plan)."""
    return dispatch.dispatch_id or f"{dispatch.task}:{dispatch.plan_id}"
