"""What the soak scripts share: a sibling script, a router, RSS, and an
executor that follows the README's receiver rules.

The scripts of ``tools/`` have no ``.py`` suffix, so they are loaded by
path (:func:`load_script`); tests load them the same way.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import queue
import sys
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import msgspec
import zenoh

from fsw_scheduler.bus.session import listening_endpoints, loopback_config
from fsw_scheduler.testing import Fence
from fsw_scheduler.wire import messages
from fsw_scheduler.wire import topics as keys

if TYPE_CHECKING:
    from types import ModuleType

TOOLS = Path(__file__).resolve().parent


def load_script(name: str, module: str | None = None) -> ModuleType:
    """The script ``tools/<name>`` loaded as the module ``module``."""
    module = module or name
    loader = importlib.machinery.SourceFileLoader(module, str(TOOLS / name))
    spec = importlib.util.spec_from_loader(module, loader)
    assert spec is not None
    loaded = importlib.util.module_from_spec(spec)
    # dataclasses look their module up in sys.modules.
    sys.modules[module] = loaded
    loader.exec_module(loaded)
    return loaded


def start_router(
    connect: tuple[str, ...] = (), lease_ms: int | None = None
) -> tuple[zenoh.Session, int]:
    """A Zenoh router on loopback, as between the computers of a craft
    (``connect``: other routers it meshes with; ``lease_ms``: its Zenoh
    lease, so that a silent link to another router ends within it)."""
    config = loopback_config(listen="tcp/127.0.0.1:0", connect=connect)
    config.insert_json5("mode", '"router"')
    if lease_ms is not None:
        config.insert_json5("transport/link/tx/lease", str(lease_ms))
    # Back on a router that was cut off within 100 ms: the soaks decide
    # when links come back.
    config.insert_json5(
        "connect/retry",
        "{period_init_ms: 100, period_max_ms: 100, period_increase_factor: 1}",
    )
    router = zenoh.open(config)
    (endpoint,) = listening_endpoints(router)
    return router, int(endpoint.rsplit(":", 1)[1])


def _status_mb(pid: int, field: str) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) / 1024
    return 0.0


def rss_mb(pid: int) -> float:
    """The resident memory of process ``pid`` now, in MB (Linux)."""
    return _status_mb(pid, "VmRSS")


def peak_mb(pid: int) -> float:
    """The peak resident memory of process ``pid``, in MB (Linux)."""
    return _status_mb(pid, "VmHWM")


@dataclass
class Run:
    """One execution of a dispatch by :class:`ReadmeExecutor`."""

    dispatch_id: str
    start: int
    end: int
    outcome: str = "running"  # completed, cancelled, replaced
    term: int = 0


class ReadmeExecutor:
    """An executor that follows the README's receiver rules, with latency.

    It keeps the highest term and acts once per ``dispatch_id``
    (:class:`~fsw_scheduler.testing.Fence`), runs each dispatch for its
    length from the unit it received it, reports ``running`` ``late``
    units late and ``completed`` the moment its own clock reaches the end
    (before the scheduler may have seen that tick: a report racing the
    clock), obeys a cancel (stops the run, or never starts it) and answers
    ``cancelled``, and answers a blind dispatch of a task it ran under a
    lower term with its last report on that run. Everything runs on one
    worker thread; ticks come from the spacecraft's clock through
    :meth:`advance`.

    Attributes
    ----------
    runs
        Task to its executions, in order.
    raced
        ``completed`` reports sent the moment the executor's clock reached
        their ``at`` (before the tick is on the bus, in the soaks).
    """

    def __init__(
        self, session: zenoh.Session, spacecraft: str = "sat1", late: int = 1
    ) -> None:
        self.session = session
        self.topics = keys.Topics(spacecraft)
        self.late = late
        self.fence = Fence()
        self.runs: dict[str, list[Run]] = {}
        self.now = -1
        self.reports = 0
        self.raced = 0
        self.cancels = 0
        self.blind = 0
        self._last_report: dict[str, messages.ActivityReport] = {}
        self._running: dict[str, tuple[messages.Dispatch, Run]] = {}
        self._pending_running: list[tuple[int, messages.Dispatch]] = []
        self._events: queue.Queue[tuple[str, object]] = queue.Queue()
        self._stop = threading.Event()
        self._sub = session.declare_subscriber(
            self.topics.key("scheduler/**"),
            lambda s: self._events.put(
                (str(s.key_expr), s.payload.to_bytes())
            ),
        )
        self._worker = threading.Thread(target=self._work, daemon=True)
        self._worker.start()

    def advance(self, now: int) -> None:
        """The spacecraft's clock reached ``now``."""
        self._events.put(("tick", now))

    def drain(self, timeout: float = 10.0) -> None:
        """Wait until everything received so far is handled."""
        done = threading.Event()
        self._events.put(("mark", done))
        if not done.wait(timeout):
            raise TimeoutError("the executor did not keep up")

    def close(self) -> None:
        """Stop the worker and undeclare the subscriber."""
        self._stop.set()
        self._events.put(("stop", None))
        self._worker.join(10)
        self._sub.undeclare()

    def executions(self, task: str) -> int:
        """Runs of ``task`` that were not cancelled by the scheduler."""
        return sum(r.outcome != "cancelled" for r in self.runs.get(task, []))

    def executed_twice(self) -> list[str]:
        """Tasks executed more than once."""
        return sorted(t for t in self.runs if self.executions(t) > 1)

    # -- the worker ----------------------------------------------------------

    def _work(self) -> None:
        while not self._stop.is_set():
            kind, value = self._events.get()
            if kind == "stop":
                return
            if kind == "mark":
                assert isinstance(value, threading.Event)
                value.set()
            elif kind == "tick":
                assert isinstance(value, int)
                self._tick(value)
            else:
                assert isinstance(value, bytes)  # a sample's payload
                self._sample(kind, value)

    def _tick(self, now: int) -> None:
        self.now = now
        due = [p for p in self._pending_running if p[0] <= now]
        self._pending_running = [
            p for p in self._pending_running if p[0] > now
        ]
        for _, dispatch in due:
            if dispatch.task in self._running:
                run = self._running[dispatch.task][1]
                self._report(dispatch, "running", run.start)
        for task, (dispatch, run) in sorted(self._running.items()):
            if now >= run.end:
                del self._running[task]
                run.outcome = "completed"
                # Sent as the tick arrives on board: it races the tick.
                self.raced += 1
                self._report(dispatch, "completed", now)

    def _sample(self, key: str, payload: bytes) -> None:
        kind = self.topics.schema_kind(key)
        if kind == "term":
            self.fence.admit(msgspec.json.decode(payload, type=messages.Term))
            return
        if kind in ("plan", "status"):
            decoded = msgspec.json.decode(payload)
            self.fence.admit(_Termed(decoded.get("term", 0)))
            return
        if kind != "dispatch":
            return
        dispatch = msgspec.json.decode(payload, type=messages.Dispatch)
        if self.fence.cancel(dispatch):
            self._cancel(dispatch)
        elif (earlier := self.fence.earlier_run(dispatch)) is not None:
            self._report_again(dispatch.task, earlier)
        elif self.fence.execute(dispatch):
            self._start(dispatch)

    def _start(self, dispatch: messages.Dispatch) -> None:
        now = max(self.now, 0)
        task = dispatch.task
        if task in self._running:
            # A new id for a running task replaces its command (the old
            # rule): that is the second execution this soak looks for.
            self._running.pop(task)[1].outcome = "replaced"
        run = Run(
            dispatch.dispatch_id,
            now,
            now + dispatch.end - dispatch.start,
            term=dispatch.term,
        )
        self.runs.setdefault(task, []).append(run)
        self._running[task] = (dispatch, run)
        self._pending_running.append((now + self.late, dispatch))

    def _report_again(self, task: str, dispatch_id: str) -> None:
        """Send the last report on the run ``dispatch_id`` of ``task``
        again (a new commander commanded the task blind)."""
        self.blind += 1
        last = self._last_report.get(dispatch_id)
        if last is not None:
            self._put(last)

    def _cancel(self, dispatch: messages.Dispatch) -> None:
        self.cancels += 1
        task = dispatch.task
        current = self._running.get(task)
        if current is not None and current[0].dispatch_id == (
            dispatch.dispatch_id
        ):
            del self._running[task]
            current[1].outcome = "cancelled"
            current[1].end = max(self.now, 0)
        elif any(
            r.dispatch_id == dispatch.dispatch_id
            and r.outcome in ("completed", "replaced")
            for r in self.runs.get(task, [])
        ):
            return  # it ended and said so: that report answers
        self._report(dispatch, "cancelled", max(self.now, 0))

    def _report(
        self,
        dispatch: messages.Dispatch,
        state: Literal["running", "completed", "cancelled"],
        at: int,
    ) -> None:
        self.reports += 1
        report = messages.ActivityReport(
            dispatch.task,
            state,
            at,
            dispatch_id=dispatch.dispatch_id,
            term=dispatch.term,
        )
        self._last_report[dispatch.dispatch_id] = report
        self._put(report)

    def _put(self, report: messages.ActivityReport) -> None:
        self.session.put(
            self.topics.activity_report(report.task),
            messages.encode(report),
            congestion_control=zenoh.CongestionControl.BLOCK,
        )


@dataclass
class _Termed:
    """A message's term alone, for the fence."""

    term: int
