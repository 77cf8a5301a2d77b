"""Record bus traffic to MCAP and replay it onto the bus.

:func:`record` subscribes with a bounded FIFO channel, so Zenoh's network
thread only enqueues samples and never runs our code; a single loop in the
calling thread drains the channel and writes to a
:class:`~fsw_scheduler.journal.writer.Recorder`. :func:`replay` publishes a
recording back in log-time order, re-creating the recorded gaps (scaled by
``rate``) from an injectable clock and sleep function.

Encodings: each sample is recorded with its own Zenoh encoding (JSON ones
on ``json`` channels with their schema, others under their own encoding,
see :func:`~fsw_scheduler.journal.writer.mcap_encoding`), and a replay puts
each
message back with the encoding it was recorded with.

Key-expression pitfall: ``fsw/**`` never matches keys starting with ``@``
(admin space, liveliness); record those with their own key expression.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import zenoh

from ..errors import BusError
from ..journal.info import info as recording_info
from ..journal.reader import iter_messages
from ..journal.writer import PathLike, RecordedMessage
from ..wire.topics import bus_key

if TYPE_CHECKING:
    import threading
    from collections.abc import (
        Callable,
        Iterable,
        Iterator,
        Mapping,
        Sequence,
    )

    from ..journal.writer import Recorder

__all__ = [
    "KeyFilter",
    "RecordStats",
    "clock_ticks",
    "parse_remap",
    "record",
    "remap_key",
    "replay",
]

#: Default capacity of the recording channel; a full FIFO channel makes the
#: Zenoh network thread wait, so it is sized for bursts, not for steady
#: overload.
DEFAULT_CAPACITY = 4096
JSON_ENCODING = "application/json"


@dataclass
class RecordStats:
    """Counters of one :func:`record` run, updated while it runs.

    Attributes
    ----------
    received
        Samples taken from the channel.
    written
        Samples written to the recording.
    deletes
        DELETE samples seen (not recorded: they carry no JSON payload).
    errors
        Samples that could not be written.
    excluded
        Samples on keys the ``exclude`` expressions leave out.
    skipped
        Samples of another encoding than JSON, left out by a recorder made
        with ``only_json=True``.
    by_key
        Samples written per key expression.
    by_encoding
        Samples written per Zenoh encoding.
    """

    received: int = 0
    written: int = 0
    deletes: int = 0
    errors: int = 0
    excluded: int = 0
    skipped: int = 0
    by_key: dict[str, int] = field(default_factory=dict)
    by_encoding: dict[str, int] = field(default_factory=dict)


def _timestamp_ns(sample: zenoh.Sample) -> int | None:
    stamp = sample.timestamp
    if stamp is None:
        return None
    # NTP64 seconds count from the Unix epoch in Zenoh, so as_nanos() is
    # directly comparable with time.time_ns().
    return stamp.get_time_as_ntp64().as_nanos()


def record(
    session: zenoh.Session,
    key_expr: str,
    recorder: Recorder,
    stop: threading.Event,
    *,
    clock_ns: Callable[[], int] = time.time_ns,
    capacity: int = DEFAULT_CAPACITY,
    poll_interval_s: float = 0.01,
    ready: threading.Event | None = None,
    stats: RecordStats | None = None,
    exclude: Iterable[str] = (),
) -> RecordStats:
    """Record every sample on ``key_expr`` until ``stop`` is set.

    Each PUT sample becomes one MCAP message: topic = its key expression,
    payload = its bytes, encoding = its Zenoh encoding, ``log_time`` =
    ``clock_ns()`` at reception, ``publish_time`` = its Zenoh timestamp
    when it has one. While idle the
    loop calls :meth:`Recorder.tick` so that the last messages are flushed
    within the recorder's flush interval. The recorder is flushed, not
    closed, on return.

    Parameters
    ----------
    session
        Open Zenoh session.
    key_expr
        What to record, e.g. ``fsw/sat1/**``.
    recorder
        Destination.
    stop
        Set it (from any thread) to end the recording; samples already
        received are still written.
    clock_ns
        Reception clock in ns since the Unix epoch.
    capacity
        Size of the FIFO channel between Zenoh and this loop.
    poll_interval_s
        Longest wait on ``stop`` when the channel is empty.
    ready
        Set once the subscriber is declared.
    stats
        Counters to update in place (lets another thread watch progress);
        a new object when omitted.
    exclude
        Key expressions not to record (counted in ``stats.excluded``).

    Returns
    -------
    RecordStats
        The counters.

    Raises
    ------
    BusError
        If the subscriber cannot be declared (bad key expression, closed
        session).
    """
    stats = RecordStats() if stats is None else stats
    exclude = list(exclude)
    keep = KeyFilter((), exclude) if exclude else None
    try:
        subscriber = session.declare_subscriber(
            key_expr, zenoh.handlers.FifoChannel(capacity)
        )
    except zenoh.ZError as exc:
        raise BusError(f"cannot subscribe to {key_expr}: {exc}") from exc
    try:
        if ready is not None:
            ready.set()
        while True:
            stopping = stop.is_set()
            drained = _drain(subscriber, recorder, stats, clock_ns, keep)
            if stopping:
                break
            recorder.tick(clock_ns())
            if not drained:
                stop.wait(poll_interval_s)
    finally:
        subscriber.undeclare()
        recorder.flush()
    return stats


def _drain(
    subscriber: zenoh.Subscriber,
    recorder: Recorder,
    stats: RecordStats,
    clock_ns: Callable[[], int],
    keep: KeyFilter | None = None,
) -> int:
    count = 0
    while (sample := subscriber.try_recv()) is not None:
        count += 1
        stats.received += 1
        if sample.kind == zenoh.SampleKind.DELETE:
            stats.deletes += 1
            continue
        topic = str(sample.key_expr)
        if keep is not None and not keep(topic):
            stats.excluded += 1
            continue
        encoding = str(sample.encoding)
        try:
            written = recorder.write(
                topic,
                sample.payload.to_bytes(),
                log_time_ns=clock_ns(),
                publish_time_ns=_timestamp_ns(sample),
                encoding=encoding,
            )
        except (OSError, ValueError):
            # Keep recording the rest: one bad write must not end a
            # session-long recording.
            stats.errors += 1
            continue
        if not written:
            stats.skipped += 1
            continue
        stats.written += 1
        stats.by_key[topic] = stats.by_key.get(topic, 0) + 1
        stats.by_encoding[encoding] = stats.by_encoding.get(encoding, 0) + 1
    return count


class KeyFilter:
    """Include/exclude filter on recorded topics, by key expression.

    A topic passes when it intersects at least one ``include`` expression
    (or ``include`` is empty) and no ``exclude`` expression. Matching is
    Zenoh's own :meth:`zenoh.KeyExpr.intersects`, so ``*``, ``**`` and
    ``$*`` mean on replay what they mean on the bus; for recorded topics,
    which are concrete keys, "intersects" is the same as "includes".
    Decisions are cached per topic.

    Parameters
    ----------
    include
        Key expressions to keep; empty keeps everything.
    exclude
        Key expressions to drop; they win over ``include``.
    """

    def __init__(
        self, include: Iterable[str] = (), exclude: Iterable[str] = ()
    ) -> None:
        self._include = [zenoh.KeyExpr(k) for k in include]
        self._exclude = [zenoh.KeyExpr(k) for k in exclude]
        self._cache: dict[str, bool] = {}

    def __call__(self, topic: str) -> bool:
        """Return whether ``topic`` passes the filter."""
        verdict = self._cache.get(topic)
        if verdict is None:
            key = zenoh.KeyExpr(topic)
            verdict = (
                not self._include
                or any(k.intersects(key) for k in self._include)
            ) and not any(k.intersects(key) for k in self._exclude)
            self._cache[topic] = verdict
        return verdict


def parse_remap(rules: Iterable[str]) -> dict[str, str]:
    """``OLD=NEW`` strings to a remapping table.

    Raises
    ------
    ValueError
        A rule without ``=``, an empty side, or a wildcard (``*``, ``$``,
        ``?``, ``#``): remapping works on concrete key prefixes.
    """
    table: dict[str, str] = {}
    for rule in rules:
        old, sep, new = rule.partition("=")
        old, new = old.strip().strip("/"), new.strip().strip("/")
        if not sep or not old or not new:
            raise ValueError(f"--remap {rule!r}: expected OLD=NEW")
        if any(c in old + new for c in "*$?#"):
            raise ValueError(
                f"--remap {rule!r}: key prefixes only, no wildcards"
            )
        table[old] = new
    return table


def remap_key(key: str, table: Mapping[str, str]) -> str:
    """Apply the first rule whose OLD is ``key`` or a chunk prefix of it.

    ``fsw/sat1=fsw/sat2`` maps ``fsw/sat1/clock`` to ``fsw/sat2/clock``
    but leaves ``fsw/sat10/clock`` alone (prefixes end on a ``/``).
    """
    for old, new in table.items():
        if key == old:
            return new
        if key.startswith(old + "/"):
            return new + key[len(old) :]
    return key


def clock_ticks(
    messages: Iterable[RecordedMessage],
    key: str,
    origin_ns: int,
    unit_ns: int,
) -> Iterator[RecordedMessage]:
    """Interleave a bus clock with recorded messages.

    Unit ``n`` is due at ``origin_ns + n * unit_ns`` and is put on ``key``
    as ``{"now": n}`` before the first message logged at or after that
    time; the clock ends with the last message. Recorded messages on
    ``key`` itself are dropped, so subscribers see one clock.

    Parameters
    ----------
    messages
        Recorded messages in log-time order.
    key
        The clock key, e.g. ``fsw/sat1/clock``.
    origin_ns
        Log time of unit 0: the start of the recording.
    unit_ns
        Log-time nanoseconds per unit.
    """
    if unit_ns <= 0:
        raise ValueError("the clock unit must be > 0")
    due: int | None = None
    for message in messages:
        if due is None:  # the first unit at or after the first message
            due = max(0, -(-(message.log_time_ns - origin_ns) // unit_ns))
        while origin_ns + due * unit_ns <= message.log_time_ns:
            stamp = origin_ns + due * unit_ns
            yield RecordedMessage(key, b'{"now":%d}' % due, stamp, stamp)
            due += 1
        if message.topic != key:
            yield message


def replay(
    session: zenoh.Session,
    path: PathLike | Sequence[PathLike],
    *,
    rate: float = 1.0,
    burst: bool = False,
    start_offset_s: float = 0.0,
    until_s: float | None = None,
    loop: bool = False,
    include: Iterable[str] = (),
    exclude: Iterable[str] = (),
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], object] | None = None,
    stop: threading.Event | None = None,
    encoding: str | None = None,
    remap: Mapping[str, str] | None = None,
    clock_key: str | None = None,
    clock_unit_s: float = 1.0,
) -> int:
    """Publish a recording back onto the bus, in log-time order.

    Each message is put on its recorded key (after ``remap``) with the
    encoding it was recorded with. Timing is
    scheduled from the start of the pass, not from the previous message,
    so sleeping late does not accumulate drift: message ``i`` is due
    ``(log_time_i - log_time_0) / rate`` seconds after the first one.

    Parameters
    ----------
    session
        Open Zenoh session to publish from.
    path
        A recording, or the parts of a split recording.
    rate
        Speed factor: 2.0 replays twice as fast, 0.5 half as fast.
    burst
        Publish as fast as possible (order kept, no sleeping).
    start_offset_s
        Skip messages logged less than this many seconds after the first
        message of the recording.
    until_s
        Stop before messages logged this many seconds or more after the
        first message of the recording.
    loop
        Start again from the beginning after the end, until ``stop`` is
        set. A pass that publishes nothing ends the loop.
    include, exclude
        Key-expression filters, see :class:`KeyFilter`.
    clock
        Monotonic clock in seconds (injectable for tests).
    sleep
        Sleep function in seconds (injectable for tests), called only with
        positive durations. Default: ``stop.wait`` when ``stop`` is given
        (so setting it interrupts a long gap), else :func:`time.sleep`.
    stop
        Set it to end the replay early.
    encoding
        Force this Zenoh encoding on every message instead of the
        recorded ones.
    remap
        Key prefix rules ``{OLD: NEW}`` (see :func:`remap_key`), e.g.
        ``{"fsw/sat1": "fsw/sat2"}`` replays a sat1 session as sat2.
        Filters apply to the recorded keys, before remapping.
    clock_key
        Also publish a bus clock on this key (recorded key, remapped like
        the others): ``{"now": n}`` every ``clock_unit_s`` seconds of the
        recording's log time from its start (see :func:`clock_ticks`).
    clock_unit_s
        Recording seconds per clock unit.

    Returns
    -------
    int
        Number of messages published.

    Raises
    ------
    ValueError
        If ``rate`` is not positive.
    """
    if rate <= 0:
        raise ValueError(f"rate must be > 0, not {rate}")
    if clock_unit_s <= 0:
        raise ValueError(f"clock unit must be > 0, not {clock_unit_s}")
    paths = [path] if isinstance(path, str | os.PathLike) else list(path)
    starts = [
        d.start_ns
        for d in (recording_info(p) for p in paths)
        if d.message_count
    ]
    if not starts:
        return 0
    origin_ns = min(starts)
    start_ns = origin_ns + round(start_offset_s * 1e9)
    end_ns = None if until_s is None else origin_ns + round(until_s * 1e9)
    keep = KeyFilter(include, exclude)
    if sleep is None:
        sleep = time.sleep if stop is None else stop.wait
    publishers: dict[str, zenoh.Publisher] = {}
    published = 0
    try:
        while stop is None or not stop.is_set():
            messages: Iterable[RecordedMessage] = (
                m
                for m in iter_messages(
                    paths if len(paths) > 1 else paths[0],
                    start_ns=start_ns,
                    end_ns=end_ns,
                )
                if keep(m.topic)
            )
            if clock_key is not None:
                messages = clock_ticks(
                    messages, clock_key, origin_ns, round(clock_unit_s * 1e9)
                )
            if remap:
                messages = (
                    m._replace(topic=remap_key(m.topic, remap))
                    for m in messages
                )
            count = _replay_pass(
                session,
                messages,
                publishers,
                rate=rate,
                burst=burst,
                clock=clock,
                sleep=sleep,
                stop=stop,
                encoding=encoding,
            )
            published += count
            if not loop or count == 0:
                break
    finally:
        for publisher in publishers.values():
            publisher.undeclare()
    return published


def _replay_pass(
    session: zenoh.Session,
    messages: Iterable[RecordedMessage],
    publishers: dict[str, zenoh.Publisher],
    *,
    rate: float,
    burst: bool,
    clock: Callable[[], float],
    sleep: Callable[[float], object],
    stop: threading.Event | None,
    encoding: str | None,
) -> int:
    count = 0
    first_ns: int | None = None
    wall0 = 0.0
    for message in messages:
        if stop is not None and stop.is_set():
            break
        if not burst:
            if first_ns is None:
                first_ns, wall0 = message.log_time_ns, clock()
            due = wall0 + (message.log_time_ns - first_ns) / 1e9 / rate
            delay = due - clock()
            if delay > 0:
                sleep(delay)
                if stop is not None and stop.is_set():
                    break
        # A dispatch goes back on its task's key (journal channel: all).
        key = bus_key(message.topic, message.payload)
        publisher = publishers.get(key)
        if publisher is None:
            publisher = session.declare_publisher(key)
            publishers[key] = publisher
        publisher.put(message.payload, encoding=encoding or message.encoding)
        count += 1
    return count


def recorded_spacecraft(
    paths: PathLike | Sequence[PathLike], remap: Mapping[str, str] | None
) -> set[str]:
    """The ``fsw/<sc>`` roots a replay of ``paths`` would publish under."""
    files = [paths] if isinstance(paths, str | os.PathLike) else list(paths)
    roots = set()
    for path in files:
        for channel in recording_info(path).channels:
            topic = remap_key(channel.topic, remap) if remap else channel.topic
            parts = topic.split("/")
            if len(parts) > 2 and parts[0] == "fsw":
                roots.add("/".join(parts[:2]))
    return roots


def live_schedulers(
    session: zenoh.Session, roots: Iterable[str], timeout: float = 1.0
) -> dict[str, list[str]]:
    """The schedulers alive on the bus under each root (liveliness).

    A recording replayed into a bus where one of them runs would drive
    it: its clock, its goals, its reports (``replay`` refuses, unless
    ``--into-live``).
    """
    found: dict[str, list[str]] = {}
    for root in sorted(roots):
        for suffix in ("scheduler/alive", "scheduler/nodes/**"):
            try:
                replies = session.liveliness().get(
                    f"{root}/{suffix}", timeout=timeout
                )
                for reply in replies:
                    if reply.ok is not None:
                        found.setdefault(root, []).append(
                            str(reply.ok.key_expr)
                        )
            except zenoh.ZError:
                continue
    return found
