"""Tests of :func:`fsw_scheduler.bus.client.query_payload`: a query no one
answers is asked again until its timeout, so a queryable that appears (or
that a router routes to) a moment later still answers; an error reply
ends it at once."""

from __future__ import annotations

import threading
import time

import zenoh

from fsw_scheduler.bus.client import query_payload
from fsw_scheduler.bus.session import listening_endpoints, loopback_config

from .peers import matching

KEY = "fsw/sat1/scheduler/status"


def _pair() -> tuple[zenoh.Session, zenoh.Session]:
    """Two loopback peers, the second connected to the first."""
    first = zenoh.open(loopback_config())
    second = zenoh.open(
        loopback_config(listen=None, connect=listening_endpoints(first))
    )
    return first, second


class _Counted:
    """A session whose queries are counted (each sets ``asked``)."""

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self.asked = threading.Event()

    def get(
        self, key: str, *, timeout: float, payload: bytes | None
    ) -> zenoh.Handler[zenoh.Reply]:
        replies = self.session.get(key, timeout=timeout, payload=payload)
        self.asked.set()
        return replies


def test_a_queryable_that_comes_late_still_answers() -> None:
    """Tests that a query sent before any queryable exists gets the
    answer of one declared while it waits, not None at once."""
    server, client = _pair()
    try:
        counted = _Counted(client)
        answers: list[bytes | None] = []
        asking = threading.Thread(
            target=lambda: answers.append(
                # A stand-in for the session: query_payload only calls get.
                query_payload(counted, KEY, 30.0)  # type: ignore[arg-type]
            )
        )
        asking.start()
        # Asked once, with no one to answer, before the queryable exists.
        assert counted.asked.wait(10)
        queryable = server.declare_queryable(
            KEY, lambda query: query.reply(KEY, b'{"state": "ok"}')
        )
        asking.join(30)
        assert not asking.is_alive()
        assert answers == [b'{"state": "ok"}']
        queryable.undeclare()
    finally:
        client.close()
        server.close()


def test_no_answer_waits_for_the_timeout() -> None:
    """Tests that a query no one answers returns None at its timeout, not
    before (it is asked again meanwhile)."""
    server, client = _pair()
    try:
        began = time.monotonic()
        assert query_payload(client, KEY, 0.5) is None
        assert 0.5 <= time.monotonic() - began < 5.0
    finally:
        client.close()
        server.close()


def test_an_error_reply_ends_the_query_at_once() -> None:
    """Tests that an error reply (no plan yet) is an answer: None at
    once, not a wait for the timeout."""
    server, client = _pair()
    try:
        queryable = server.declare_queryable(
            KEY, lambda query: query.reply_err(b"no plan yet")
        )
        reached = False
        deadline = time.monotonic() + 10
        querier = client.declare_querier(KEY)
        while time.monotonic() < deadline and not reached:
            reached = matching(querier)
        querier.undeclare()
        assert reached
        began = time.monotonic()
        assert query_payload(client, KEY, 30.0) is None
        assert time.monotonic() - began < 10.0
        queryable.undeclare()
    finally:
        client.close()
        server.close()
