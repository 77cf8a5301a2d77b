"""Tests of the stop on SIGINT and SIGTERM of the long-running commands:
a signal landing while the main thread waits on the stop itself must
stop it, never hang it."""

from __future__ import annotations

import subprocess
import sys
import textwrap

#: A main thread that spins on ``stop.wait(0)``, so that most signals land
#: while it holds the event's lock; each round a timer thread signals the
#: process, and the round ends when the stop is seen.
_SPIN = textwrap.dedent(
    """\
    import os, signal, sys, threading
    from fsw_scheduler.app.cli.stopping import stop_on_signals

    stop = threading.Event()
    seen = []
    stop_on_signals(stop, seen.append)
    signum = getattr(signal, sys.argv[1])
    for _ in range(int(sys.argv[2])):
        stop.clear()
        threading.Timer(0.001, os.kill, (os.getpid(), signum)).start()
        while not stop.is_set():
            stop.wait(0)
    print(len(seen), sorted(set(seen)) == [signum], flush=True)
    """
)


def _spin(signame: str, rounds: int) -> str:
    done = subprocess.run(
        [sys.executable, "-c", _SPIN, signame, str(rounds)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_a_sigterm_while_the_main_thread_waits_on_the_stop_stops_it() -> None:
    """Tests 200 SIGTERMs landing in a main thread busy in ``stop.wait``:
    each sets the stop (a handler calling ``Event.set`` hangs on the first
    one or few, on the lock its own thread holds), and the note hears each."""
    assert _spin("SIGTERM", 200) == "200 True"


def test_sigint_stops_too() -> None:
    """Tests that Ctrl-C is a stop like SIGTERM, not a KeyboardInterrupt."""
    assert _spin("SIGINT", 20) == "20 True"


def test_a_note_that_fails_still_stops() -> None:
    """Tests that the stop is set even when the note that says why
    raises (a logging fault must not keep the command running)."""
    script = textwrap.dedent(
        """\
        import os, signal, threading
        from fsw_scheduler.app.cli.stopping import stop_on_signals

        def note(signum):
            raise RuntimeError("no log")

        stop = threading.Event()
        stop_on_signals(stop, note)
        threading.Timer(0.001, os.kill, (os.getpid(), signal.SIGTERM)).start()
        print(stop.wait(30), flush=True)
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "True"
