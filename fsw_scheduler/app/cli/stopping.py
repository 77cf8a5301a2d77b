"""SIGINT and SIGTERM as a stop the long-running commands can wait on.

A Python signal handler runs in the main thread between two bytecodes,
wherever that thread happens to be. A handler that calls
``threading.Event.set`` takes the event's lock; if the signal lands while
the main thread is inside ``Event.wait`` of the same event, between taking
that lock and releasing it, the handler waits on a lock its own thread
holds, and a plain lock is not reentrant: the process hangs for ever,
alive, on a SIGTERM meant to stop it (seen once in CI: ``ros2-bridge``
polls its stop every 10 ms).

So the handlers here do nothing in Python. Python's C-level handler writes
the signal's number into a pipe (:func:`signal.set_wakeup_fd`) the moment
the signal arrives, and one daemon thread reads the pipe and sets the stop:
from another thread, ``Event.set`` only waits for the main thread to let
go of the lock, which it does.
"""

from __future__ import annotations

import os
import signal
import threading
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable

#: The signals that stop a long-running command.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _Watcher:
    """The process's one pipe from the signal handler to a stop event."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._stop: threading.Event | None = None
        self._note: Callable[[int], None] | None = None
        self._started = False

    def watch(
        self, stop: threading.Event, note: Callable[[int], None] | None
    ) -> None:
        """Make ``stop`` the event the next signal sets (the only one)."""
        with self._lock:
            self._stop, self._note = stop, note
            if self._started:
                return
            read, write = os.pipe()
            os.set_blocking(write, False)
            # The C-level handler must never block on a full pipe; a byte
            # lost when 512 signals are unread changes nothing: one stops.
            signal.set_wakeup_fd(write, warn_on_full_buffer=False)
            threading.Thread(
                target=self._read, args=(read,), name="signals", daemon=True
            ).start()
            self._started = True

    def _read(self, read: int) -> None:
        while True:
            data = os.read(read, 64)
            for signum in data:
                if signum not in STOP_SIGNALS:
                    continue
                with self._lock:
                    stop, note = self._stop, self._note
                try:
                    if note is not None:
                        note(signum)
                finally:
                    # A note that fails must not keep the command running.
                    if stop is not None:
                        stop.set()


_WATCHER = _Watcher()


def _nothing(_signum: int, _frame: object) -> None:
    """The Python-level handler: the watcher thread acts (module doc)."""


def stop_on_signals(
    stop: threading.Event, note: Callable[[int], None] | None = None
) -> None:
    """Set ``stop`` on SIGINT or SIGTERM (the long-running commands: they
    finish what they hold, then exit 0).

    Safe against the signal landing while the main thread waits on
    ``stop`` itself (module doc). Call it from the main thread; a second
    call replaces the event the signals set.

    Parameters
    ----------
    stop
        The event to set.
    note
        Called with the signal's number before ``stop`` is set (from the
        watcher thread), to say why the command stops.
    """
    _WATCHER.watch(stop, note)
    for sig in STOP_SIGNALS:
        signal.signal(sig, _nothing)
