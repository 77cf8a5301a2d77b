"""A commander's lease on the bus: never command on a view that has gaps.

The others take over when this node's liveliness tokens vanish, which
Zenoh decides after its lease (``transport/link/tx/lease``, 10 s by
default) for a silent link, at once for a closed one. A node that was
stopped (SIGSTOP, a hung hypervisor) or whose every link fell silent
cannot know whether that happened: it must assume it was replaced. So a
commanding node watches its own view of the bus:

* a **gap**: a watchdog thread beats every :data:`BEAT_S`; if the time
  between two beats (or between the last beat and a check from the loop,
  whichever thread runs first after the process continues) exceeds
  :data:`GAP_SHARE` of the lease, the process was not running. A gap
  shorter than the whole lease is a *hiccup*: the others cannot have
  taken over yet (they wait the lease, then confirm), so the node
  re-verifies before its next output (asks the bus who commands) and
  goes on commanding in its term if no one else does. A longer gap ends
  the lease;
* **isolation**: the session had a link to a router or a peer and now has
  none (Zenoh closed them after their lease), and other schedulers were
  seen: a node that never saw another one is alone on its computer, and
  its last link going (a peer-mode tool that connected and left) is no
  partition.

An ended lease is for good: the node stops commanding before its next
output, and the election starts again (re-verify: it commands again only
in a new term, if no one else commands). See docs/redundancy.md.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable

    import zenoh

log = logging.getLogger("fsw_scheduler.redundancy")

#: Seconds between the watchdog's beats.
BEAT_S = 0.05
#: A gap longer than this share of the Zenoh lease makes the node ask the
#: bus who commands before its next output (a hiccup); a gap of the whole
#: lease ends its lease: the others may have replaced it by then (they
#: wait the whole lease, then confirm). Below the lease, with room for a
#: loaded host.
GAP_SHARE = 0.5
#: Zenoh's default ``transport/link/tx/lease``, in seconds.
DEFAULT_LEASE_S = 10.0


def zenoh_lease_s(config: zenoh.Config) -> float:
    """The link lease of a Zenoh configuration, in seconds."""
    try:
        value = config.get_json("transport/link/tx/lease")
        return float(value) / 1000.0 if value else DEFAULT_LEASE_S
    except Exception:  # an older zenoh without get_json: its default
        return DEFAULT_LEASE_S


def has_links(session: zenoh.Session) -> bool:
    """Whether the session has a link to any router or peer now."""
    info = session.info
    return bool(list(info.routers_zid()) or list(info.peers_zid()))


class Lease:
    """Whether this node may still command (see the module docstring).

    Parameters
    ----------
    lease_s
        The Zenoh link lease, in seconds.
    linked
        Whether the session has a link now (None: isolation is not
        watched, as for a node alone on its computer).
    seconds
        The monotonic clock.
    """

    def __init__(
        self,
        lease_s: float,
        linked: Callable[[], bool] | None = None,
        seconds: Callable[[], float] = time.monotonic,
    ) -> None:
        self.gap_s = GAP_SHARE * lease_s
        self.lease_s = lease_s
        #: Hiccups (gaps under the lease) re-verified so far.
        self.hiccups = 0
        self._hiccup: float | None = None
        self._linked = linked
        self._seconds = seconds
        self._beat = seconds()
        self._was_linked = False
        self._lost: str | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=self._watch, name="fsw-lease", daemon=True
        )

    def start(self) -> Lease:
        """Start the watchdog."""
        self._beat = self._seconds()
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the watchdog."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(1.0)

    def lost(self) -> str | None:
        """Why the lease ended (None: it holds). Call before commanding."""
        if self._lost is None:
            self._check(self._seconds())
        return self._lost

    def hiccup(self) -> float | None:
        """A gap under the lease not yet re-verified (its seconds), once;
        the caller re-verifies before it commands again."""
        if self._lost is None:
            self._check(self._seconds())
        gap, self._hiccup = self._hiccup, None
        return gap

    def _watch(self) -> None:
        while not self._stop.wait(BEAT_S):
            self._check(self._seconds())
            if self._lost is not None:
                return

    def _check(self, now: float) -> None:
        if self._lost is not None:
            return
        gap = now - self._beat
        if gap >= self.lease_s:
            self._end(f"this process did not run for {gap:.1f} s")
            return
        if gap > self.gap_s:
            self.hiccups += 1
            self._hiccup = max(gap, self._hiccup or 0.0)
            log.warning(
                "this process did not run for %.1f s (under the %.1f s "
                "lease): re-verifying before the next command",
                gap,
                self.lease_s,
            )
        self._beat = max(self._beat, now)
        if self._linked is None:
            return
        try:
            linked = self._linked()
        except Exception:  # a closing session: nothing to decide on
            return
        if linked:
            self._was_linked = True
        elif self._was_linked:
            self._end("every link to the bus was lost")

    def _end(self, reason: str) -> None:
        self._lost = reason
        log.warning("lease lost: %s; this node stops commanding", reason)
