"""CBC runs that report their progress and end within the caller's limit.

:class:`WatchedCbcRun` is a :class:`~.cbc.CbcRun` with two additions:

* **Progress.** CBC's log goes to a file, where the C library buffers it
  until CBC exits. With coreutils' ``libstdbuf`` preloaded (what
  ``stdbuf -oL`` does, without the extra exec of ``stdbuf`` itself),
  CBC writes it line by line; a watcher thread reads the new lines
  every :data:`PROGRESS_S` seconds and logs the incumbent, the bound and
  the gap on the ``fsw_scheduler.solver`` logger (the CLI prints it on
  stderr). Where the library is not found next to ``stdbuf``, CBC is
  started through ``stdbuf``; without either only the elapsed time is
  logged.
* **A limit that holds.** CbcRun interrupts CBC shortly before the end of
  its share and kills it :data:`~.cbc.GRACE_S` later, so a CBC that does
  not answer the interrupt (it does not during a long root LP) overran
  the limit by up to that grace. Here the interrupt comes that much
  earlier for limits long enough to spare it, so that the kill falls
  within :data:`KILL_MARGIN_S` of the end of CBC's share; unless CBC has
  begun its search on a model of at most :data:`SEARCH_ENTRIES` entries
  by then: in its search it answers between nodes, so the interrupt
  comes :data:`SEARCH_EARLY_S` before the deadline instead, and the
  kill at the same time as before.
"""

from __future__ import annotations

import functools
import logging
import os
import re
import shutil
import subprocess
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING

from .cbc import GRACE_S, CbcRun

if TYPE_CHECKING:
    from collections.abc import Callable

#: Seconds between two progress lines.
PROGRESS_S = 3.0

#: Seconds past the end of CBC's share at which a silent CBC is killed.
KILL_MARGIN_S = 0.3

#: Deadlines shorter than this keep CbcRun's own interrupt (their grace
#: is a larger share, and small models answer the interrupt at once).
SHORT_S = 1.0

#: A model of at most this many matrix entries whose CBC has begun its search
#: (its log says "After N nodes") when the early interrupt is due is
#: interrupted :data:`SEARCH_EARLY_S` before its deadline instead, and killed
#: when it was before (:data:`KILL_MARGIN_S` after the deadline): in its search
#: CBC answers an interrupt between nodes. On a 15-task time-indexed model of
#: 2,800 columns and 21,324 entries (66 ms a node, root done at 0.64 s) CBC
#: exited 32-150 ms after SIGINTs sent in its search; in its root, after up to
#: 500 ms, and one sent while it read the model was lost (it ran to its end,
#: 3.3 s). The early interrupt had cut 0.7 s off every run of more than a
#: second: the fuzz shape of seed 613 (38 tasks, H = 300), whose whole model
#: narrowed CBC proves in 4.0 s, got 3.4 s of a 4.4 s share at a 10 s limit and
#: was answered `feasible`.
SEARCH_ENTRIES = 30_000
SEARCH_EARLY_S = 0.1

#: CBC's log line of its search's progress (its first once the root is
#: done), and the one of a restart (a root again, of a reduced model).
_SEARCHING = re.compile(r"^Cbc0010I After \d+ nodes", re.MULTILINE)
_RESTART = re.compile(r"^Cbc0044I .*restarting search", re.MULTILINE)


def _searching(path: str) -> bool:
    """True if the CBC log at ``path`` shows it in its search (past its
    root, and past the root of its last restart)."""
    try:
        text = Path(path).read_text(errors="replace")
    except OSError:
        return False
    searched = [m.start() for m in _SEARCHING.finditer(text)]
    restarts = [m.start() for m in _RESTART.finditer(text)]
    return bool(searched) and (not restarts or searched[-1] > restarts[-1])


#: CBC options when a MIP start is given. Its primal heuristics (rounding,
#: feasibility pump, RINS...) then mostly repeat what the start plan
#: already did: on the 67 broad campaign models that need a solve, CBC's
#: CPU time went 58.5 -> 49.3 s with them off (6 problems faster by over
#: 20 %, 1 slower), where cuts off (59.8 s, 11 slower) and the
#: feasibility pump alone off (54.0 s) did less.
WITH_START = ["heuristics off"]

#: CBC options when a MIP start is given to the disjunctive model: its
#: cuts (probing, Gomory, two-MIR on the big-M order rows) cost more per
#: node than they save in nodes. 15-task multiple problems, paper and
#: broad, all in the disjunctive model: 14.2 -> 9.3 s in total (c15-
#: multiple-3 1.33 -> 0.30 s, b15-multiple-3 7.1 -> 2.4 s); binary ones
#: (with the rows of :mod:`.disjunctive.energy`) 1.59 -> 0.91 s. With
#: heuristics on as well the multiple ones took 18.1 s.
WITH_START_DISJUNCTIVE = [*WITH_START, "cuts off"]

log = logging.getLogger("fsw_scheduler.solver")

_FLOAT = r"(-?[0-9.]+(?:e[+-]?[0-9]+)?)"
_INCUMBENT = [
    re.compile(r"Integer solution of " + _FLOAT, re.IGNORECASE),
    re.compile(r"solution with cost " + _FLOAT, re.IGNORECASE),
    re.compile(r"After \d+ nodes, \d+ on tree, " + _FLOAT + " best solution"),
]
_BOUND = [
    re.compile(r"best possible " + _FLOAT),
    re.compile(r"Continuous objective value is " + _FLOAT),
]


#: Where coreutils installs ``libstdbuf.so``, from ``stdbuf``'s directory
#: (Debian, Arch; Fedora; Alpine, Homebrew).
_LIBSTDBUF = (
    "../libexec/coreutils/libstdbuf.so",
    "../lib64/coreutils/libstdbuf.so",
    "../lib/coreutils/libstdbuf.so",
)


@functools.cache
def _stdbuf() -> str | None:
    return shutil.which("stdbuf")


@functools.cache
def _libstdbuf() -> str | None:
    """coreutils' ``libstdbuf.so``, the library ``stdbuf`` preloads."""
    stdbuf = _stdbuf()
    if stdbuf is None:
        return None
    bindir = Path(stdbuf).resolve().parent
    for relative in _LIBSTDBUF:
        candidate = (bindir / relative).resolve()
        if candidate.is_file():
            return str(candidate)
    return None


def line_buffered(environ: dict[str, str]) -> dict[str, str] | None:
    """``environ`` with stdout line-buffered as by ``stdbuf -oL``.

    None when ``libstdbuf`` is not found.
    """
    library = _libstdbuf()
    if library is None:
        return None
    preload = environ.get("LD_PRELOAD")
    return {
        **environ,
        "LD_PRELOAD": library if not preload else f"{library}:{preload}",
        "_STDBUF_O": "L",
    }


class LogState:
    """Incumbent and bound read so far from a CBC log (objective offset
    ``constant`` added back)."""

    def __init__(
        self, constant: float = 0.0, incumbent: float | None = None
    ) -> None:
        self.constant = constant
        self.incumbent = incumbent
        self.bound: float | None = None

    def feed(self, line: str) -> None:
        """Update from one log line."""
        for pattern in _INCUMBENT:
            match = pattern.search(line)
            if match:
                value = float(match.group(1)) + self.constant
                if value < 1e49 and (
                    self.incumbent is None or value < self.incumbent
                ):
                    self.incumbent = value
        for pattern in _BOUND:
            match = pattern.search(line)
            if match:
                value = float(match.group(1)) + self.constant
                if self.bound is None or value > self.bound:
                    self.bound = value

    def summary(self) -> str:
        """``incumbent X, bound Y, gap Z %`` with what is known."""
        inc = "none" if self.incumbent is None else f"{self.incumbent:.0f}"
        bound = "none" if self.bound is None else f"{self.bound:.0f}"
        gap = "-"
        if self.incumbent is not None and self.bound is not None:
            spread = self.incumbent - self.bound
            gap = f"{100 * spread / max(1.0, abs(self.incumbent)):.2f} %"
        return f"incumbent {inc}, bound {bound}, gap {gap}"


class _Watcher:
    """Reads a growing log file now and then and logs the progress."""

    def __init__(self, path: str, state: LogState, every_s: float) -> None:
        self.path = path
        self.state = state
        self.every_s = every_s
        self.began = time.monotonic()
        self._done = threading.Event()
        self._offset = 0
        self._thread = threading.Thread(
            target=self._loop, name="cbc-progress", daemon=True
        )
        self._thread.start()

    def _read(self) -> None:
        try:
            with open(self.path, errors="replace") as lines:
                lines.seek(self._offset)
                text = lines.read()
        except OSError:
            return
        # Only whole lines; the rest is read next time.
        complete = text.rfind("\n") + 1
        self._offset += len(text[:complete].encode(errors="replace"))
        for line in text[:complete].splitlines():
            self.state.feed(line)

    def _loop(self) -> None:
        while not self._done.wait(self.every_s):
            self._read()
            log.info(
                "cbc running %.0f s: %s",
                time.monotonic() - self.began,
                self.state.summary(),
            )

    def stop(self) -> None:
        self._done.set()
        self._thread.join()


class WatchedCbcRun(CbcRun):
    """A :class:`~.cbc.CbcRun` that logs progress and ends within its limit.

    Parameters
    ----------
    constant
        The program's objective constant, added to the values in the log.
    incumbent
        The objective of the MIP start, if any (CBC logs it only once it
        has checked it, after the root LP).
    every_s
        Seconds between progress lines (default :data:`PROGRESS_S`).
    extra
        CBC options added to CbcRun's, e.g. :data:`WITH_START`.
    **options
        As for :class:`~.cbc.CbcRun`.
    """

    def __init__(
        self,
        *,
        constant: float = 0.0,
        incumbent: float | None = None,
        every_s: float | None = None,
        extra: list[str] | None = None,
        **options: object,
    ) -> None:
        super().__init__(**options)  # type: ignore[arg-type]
        self.options += extra or []
        self.constant = constant
        self.incumbent = incumbent
        self.every_s = PROGRESS_S if every_s is None else every_s
        self._log_path = ""

    def _run(
        self, args: list[str], log_path: str, deadline: float | None
    ) -> int:
        self._log_path = log_path
        stdbuf = _stdbuf()
        if stdbuf is not None and self._environment() is None:
            args = [stdbuf, "-oL", *args]
        watcher = _Watcher(
            log_path, LogState(self.constant, self.incumbent), self.every_s
        )
        try:
            return super()._run(args, log_path, deadline)
        finally:
            watcher.stop()

    def _environment(self) -> dict[str, str] | None:
        return line_buffered(dict(os.environ))

    def _wait(
        self,
        process: subprocess.Popen,
        deadline: float | None,
        stop: Callable[[subprocess.Popen], None] | None = None,
    ) -> None:
        if deadline is None or deadline <= SHORT_S:
            super()._wait(process, deadline, stop)
            return
        early = max(deadline - GRACE_S + KILL_MARGIN_S, SHORT_S)
        if (
            stop is not None
            or self.entries > SEARCH_ENTRIES
            or self.grace_s > GRACE_S
        ):
            super()._wait(process, early, stop)
            return
        began = time.monotonic()

        def interrupt(process: subprocess.Popen) -> None:
            # At the early interrupt; in its search CBC gets it at the
            # deadline instead, and is killed when it would have been
            # (see SEARCH_ENTRIES).
            if not _searching(self._log_path):
                self._stop(process)
                return
            at = deadline - SEARCH_EARLY_S
            try:
                process.wait(max(0.0, at - (time.monotonic() - began)))
            except subprocess.TimeoutExpired:
                self._stop(process, early + GRACE_S - at)

        super()._wait(process, early, interrupt)
