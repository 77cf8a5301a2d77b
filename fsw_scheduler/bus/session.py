"""Zenoh session configuration and small waiting helpers.

The command-line flags mirror zenoh-python's ``examples/common/common.py``
so that every ``fsw-scheduler`` command is configured like any Zenoh tool:
``--mode``, ``--connect``, ``--listen``, ``--config``, ``--cfg`` and
``--no-multicast-scouting``. Zenoh settings stay in Zenoh's own JSON5; this
module only layers the flags on top of it.

Port discovery
--------------
Tests and in-process demos listen on ``tcp/127.0.0.1:0`` and let the OS pick
the port. The port actually bound is read back from the session's own admin
space (``@/<zid>/<whatami>`` replies with its ``locators``), which
:func:`loopback_config` enables read-only. Picking a free port beforehand by
binding a socket and closing it would race with other processes grabbing the
same port between the close and Zenoh's bind; the admin space answer is the
port Zenoh really holds.
"""

from __future__ import annotations

import contextlib
import json
import re
import threading
import time
from typing import TYPE_CHECKING

import zenoh

from ..errors import BusError, ConfigError

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable, Iterator, Sequence

__all__ = [
    "add_zenoh_arguments",
    "listening_endpoints",
    "loopback_config",
    "open_peer_pair",
    "settings_file",
    "wait_connected",
    "wait_matching",
    "wait_until",
    "zenoh_config",
]

#: Default time allowed for loopback peers to find each other.
DEFAULT_TIMEOUT_S = 10.0


def add_zenoh_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the standard Zenoh flags to a command-line parser.

    Parameters
    ----------
    parser
        The parser (or sub-parser) to extend. The flags are ``--mode``,
        ``--connect`` (repeatable), ``--listen`` (repeatable), ``--config``,
        ``--cfg KEY:VALUE`` (repeatable) and ``--no-multicast-scouting``;
        :func:`zenoh_config` turns the parsed namespace into a
        :class:`zenoh.Config`.
    """
    group = parser.add_argument_group("zenoh")
    group.add_argument(
        "--mode",
        "-m",
        choices=["peer", "client", "router"],
        help="The Zenoh session mode (default: Zenoh's, peer).",
    )
    group.add_argument(
        "--connect",
        "-e",
        metavar="ENDPOINT",
        action="append",
        help="Endpoint to connect to, e.g. tcp/10.0.0.1:7447 (repeatable).",
    )
    group.add_argument(
        "--listen",
        "-l",
        metavar="ENDPOINT",
        action="append",
        help="Endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable).",
    )
    group.add_argument(
        "--config",
        "-c",
        metavar="FILE",
        action="append",
        default=[],
        help=(
            "A Zenoh configuration file (JSON5). The scheduler's own "
            "settings (TOML) go under --settings; a .toml file here is "
            "still read as settings by 'run', with a deprecation message."
        ),
    )
    group.add_argument(
        "--cfg",
        metavar="KEY:VALUE",
        action="append",
        default=[],
        help=(
            "Any configuration change as KEY:VALUE, where KEY is a config "
            "path and VALUE is JSON5, e.g. "
            "--cfg='transport/unicast/max_links:2' (repeatable)."
        ),
    )
    group.add_argument(
        "--no-multicast-scouting",
        action="store_true",
        default=False,
        help="Disable multicast scouting.",
    )


def zenoh_config_file(args: argparse.Namespace) -> str | None:
    """The last ``--config`` file that is not a ``.toml`` file."""
    files = getattr(args, "config", None) or []
    if isinstance(files, str):
        files = [files]
    zenoh_files = [f for f in files if not str(f).endswith(".toml")]
    return zenoh_files[-1] if zenoh_files else None


def toml_config_file(args: argparse.Namespace) -> str | None:
    """The last ``--config`` file ending in ``.toml``, if any."""
    files = getattr(args, "config", None) or []
    if isinstance(files, str):
        files = [files]
    tomls = [f for f in files if str(f).endswith(".toml")]
    return tomls[-1] if tomls else None


#: Printed on stderr when ``--config FILE.toml`` is used for settings.
TOML_CONFIG_DEPRECATED = (
    "fsw-scheduler: deprecated: --config {path} (a .toml file) is read as "
    "the scheduler's settings; use --settings {path} (--config is for "
    "Zenoh's JSON5 configuration, as in the zenoh tools)"
)


def settings_file(
    args: argparse.Namespace, warn: Callable[[str], object] | None = None
) -> str | None:
    """The scheduler settings file: ``--settings``, else a ``.toml`` config.

    ``--config FILE.toml`` is the old way to give the settings; it keeps
    working, with a deprecation message passed to ``warn`` (default: print
    on stderr). ``--settings`` wins when both are given.

    Parameters
    ----------
    args
        Parsed arguments (``settings`` and ``config`` may be absent).
    warn
        Where the deprecation message goes.

    Returns
    -------
    str or None
        The TOML file to read, or None for the defaults.
    """
    explicit = getattr(args, "settings", None)
    old = toml_config_file(args)
    if old is not None and explicit is None:
        text = TOML_CONFIG_DEPRECATED.format(path=old)
        if warn is None:
            import sys

            print(text, file=sys.stderr)
        else:
            warn(text)
        return old
    return explicit


def zenoh_config(args: argparse.Namespace) -> zenoh.Config:
    """Build a Zenoh configuration from parsed :func:`add_zenoh_arguments`.

    Flags are applied on top of ``--config`` (or Zenoh's defaults) in the
    order mode, connect, listen, scouting, then every ``--cfg`` in order,
    so ``--cfg`` has the last word.

    Parameters
    ----------
    args
        The parsed namespace. Missing attributes are treated as not given,
        so a namespace from a parser without the Zenoh flags also works.

    Returns
    -------
    zenoh.Config
        The configuration to pass to :func:`zenoh.open`.

    Raises
    ------
    ConfigError
        If the file cannot be read or a ``--cfg`` entry is malformed or
        rejected by Zenoh.
    """
    path = zenoh_config_file(args)
    try:
        config = zenoh.Config.from_file(path) if path else zenoh.Config()
    except (zenoh.ZError, OSError) as exc:
        raise ConfigError(
            f"-c/--config {path}: {plain_zenoh_error(str(exc))}"
        ) from None
    settings: list[tuple[str, str, str]] = []
    if getattr(args, "mode", None):
        settings.append(("mode", json.dumps(args.mode), "-m/--mode"))
    if getattr(args, "connect", None):
        settings.append(
            ("connect/endpoints", json.dumps(args.connect), "-e/--connect")
        )
    if getattr(args, "listen", None):
        settings.append(
            ("listen/endpoints", json.dumps(args.listen), "-l/--listen")
        )
    if getattr(args, "no_multicast_scouting", False):
        settings.append(
            ("scouting/multicast/enabled", "false", "--no-multicast-scouting")
        )
    for entry in getattr(args, "cfg", None) or ():
        # Split on the first colon only: values such as endpoints
        # ("tcp/1.2.3.4:7447") contain colons themselves.
        key, sep, value = entry.partition(":")
        if not sep or not key:
            raise ConfigError(f"--cfg {entry!r}: expected KEY:VALUE")
        settings.append((key.strip(), value, f"--cfg {entry!r}"))
    for key, value, flag in settings:
        try:
            config.insert_json5(key, value)
        except zenoh.ZError as exc:
            # Name the flag to fix, and what Zenoh says of its value.
            given = value if flag.startswith("-") and "cfg" not in flag else ""
            raise ConfigError(
                f"{flag}{' ' + given if given else ''}: "
                f"{plain_zenoh_error(str(exc))}"
            ) from None
    return config


_RUST_AT = re.compile(r" at /\S+\.rs:\d+\.?")
_JSON5_MSG = re.compile(r'Json5Err\(Message \{ msg: "(?P<msg>.*?)", location')
_SINGLE = re.compile(r"Single\((?P<endpoint>[^)]*)\)")
_UNREACHABLE = re.compile(r"Unable to connect to any of \[(?P<what>.*)\]")
_LISTENER = re.compile(
    r"Can not create a new \w+ listener bound to (?P<endpoint>\S+?):? \[?"
    r"(?:\S+: )?(?P<why>[^(\]]*)"
)


def plain_zenoh_error(text: str) -> str:
    """A Zenoh error in one line a person can act on.

    Zenoh's messages carry Rust internals: the source file of the error
    (``at /root/.cargo/.../orchestrator.rs:447``), debug forms
    (``[Single(tcp/...)]``, ``Json5Err(Message {...})``). This keeps the
    words, names the flag to fix where the error says which, and leaves
    any other message as it is, without the internals.

    Parameters
    ----------
    text
        ``str()`` of a ``zenoh.ZError``.

    Returns
    -------
    str
        One line, without a source path.
    """
    json5 = _JSON5_MSG.search(text)
    if json5 is not None:
        words = json5.group("msg").replace("\\n", "\n")
        words = _RUST_AT.sub("", words)
        lines = [ln.strip() for ln in words.splitlines() if ln.strip()]
        said = [ln.lstrip("= ") for ln in lines if ln.startswith("=")]
        detail = said[-1] if said else lines[0] if lines else words
        if detail.startswith("expected array, boolean"):
            detail = (
                "not a JSON5 value (a string needs quotes: "
                "--cfg 'mode:\"client\"')"
            )
        return detail
    unreachable = _UNREACHABLE.search(text)
    if unreachable is not None:
        endpoints = ", ".join(
            m.group("endpoint") for m in _SINGLE.finditer(text)
        ) or unreachable.group("what")
        return (
            f"cannot reach {endpoints}: nothing answers there (check "
            "-e/--connect, and -m/--mode: a client needs a router or a "
            "node listening on that endpoint)"
        )
    listener = _LISTENER.search(text)
    if listener is not None:
        return (
            f"cannot listen on {listener.group('endpoint')}: "
            f"{listener.group('why').strip() or 'refused'} (check "
            "-l/--listen: a free port in 1..65535, an address of this "
            "machine)"
        )
    if "invalid port value" in text:
        return (
            "invalid port value (check -l/--listen and -e/--connect: "
            "ports are 1..65535)"
        )
    text = _RUST_AT.sub("", text)
    return _SINGLE.sub(lambda m: m.group("endpoint"), text).strip()


def loopback_config(
    listen: str | None = "tcp/127.0.0.1:0",
    connect: Sequence[str] = (),
) -> zenoh.Config:
    """Return an isolated peer configuration for tests and demos.

    Multicast scouting and gossip are off, so the session only talks to the
    endpoints it is given, and the open-time scouting delay is zero, so
    :func:`zenoh.open` returns at once (wait for peers with
    :func:`wait_connected` or :func:`wait_matching`); the admin space is
    enabled read-only so that :func:`listening_endpoints` can report the
    port the OS picked.

    Parameters
    ----------
    listen
        Endpoint to listen on, or ``None`` not to listen at all. Port ``0``
        asks the OS for an ephemeral port.
    connect
        Endpoints to connect to.

    Returns
    -------
    zenoh.Config
        A peer-mode configuration.
    """
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5(
        "listen/endpoints", json.dumps([listen] if listen else [])
    )
    config.insert_json5("connect/endpoints", json.dumps(list(connect)))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("scouting/gossip/enabled", "false")
    # zenoh.open() may otherwise wait up to the scouting delay (500 ms) for
    # peers to show up; callers here wait explicitly instead
    # (wait_connected, wait_matching), so opening returns at once.
    config.insert_json5("scouting/delay", "0")
    config.insert_json5("adminspace/enabled", "true")
    config.insert_json5(
        "adminspace/permissions", '{"read": true, "write": false}'
    )
    return config


def listening_endpoints(
    session: zenoh.Session, timeout_s: float = 2.0
) -> list[str]:
    """Return the locators a session is actually listening on.

    Parameters
    ----------
    session
        An open session whose configuration enables the admin space (as
        :func:`loopback_config` does).
    timeout_s
        How long to wait for the admin space to answer.

    Returns
    -------
    list of str
        Locators such as ``tcp/127.0.0.1:40123``, with the real ports.

    Raises
    ------
    BusError
        If the admin space does not answer (it is disabled by default in
        Zenoh; enable it with ``--cfg adminspace/enabled:true``).
    """
    zid = str(session.zid())
    locators: list[str] = []
    answered = False
    for reply in session.get(f"@/{zid}/*", timeout=timeout_s):
        sample = reply.ok
        if sample is None:
            continue
        try:
            doc = json.loads(sample.payload.to_bytes())
        except ValueError:
            continue
        if isinstance(doc, dict) and "locators" in doc:
            answered = True
            locators.extend(str(loc) for loc in doc["locators"])
    if not answered:
        raise BusError(
            f"session {zid} did not report its locators; is the admin "
            "space enabled (adminspace/enabled: true)?"
        )
    return locators


def wait_until(
    predicate: Callable[[], bool],
    timeout_s: float,
    *,
    interval_s: float = 0.005,
    what: str = "condition",
) -> None:
    """Poll ``predicate`` until it holds, or fail after ``timeout_s``.

    Parameters
    ----------
    predicate
        Cheap, side-effect-free check.
    timeout_s
        Deadline in seconds (monotonic clock).
    interval_s
        Pause between checks.
    what
        Description used in the error message.

    Raises
    ------
    TimeoutError
        If the predicate is still false at the deadline.
    """
    deadline = time.monotonic() + timeout_s
    pause = threading.Event()
    while not predicate():
        if time.monotonic() >= deadline:
            raise TimeoutError(f"timed out after {timeout_s} s: {what}")
        pause.wait(interval_s)


def wait_connected(
    a: zenoh.Session,
    b: zenoh.Session,
    timeout_s: float = DEFAULT_TIMEOUT_S,
) -> None:
    """Wait until two sessions list each other as connected peers.

    Parameters
    ----------
    a, b
        The two sessions.
    timeout_s
        Deadline in seconds.

    Raises
    ------
    TimeoutError
        If they do not see each other in time.
    """
    zid_a, zid_b = str(a.zid()), str(b.zid())

    def _see_each_other() -> bool:
        peers_a = {str(z) for z in a.info.peers_zid()}
        peers_b = {str(z) for z in b.info.peers_zid()}
        return zid_b in peers_a and zid_a in peers_b

    wait_until(_see_each_other, timeout_s, what=f"{zid_a} <-> {zid_b}")


def wait_matching(
    session: zenoh.Session,
    key_expr: str,
    timeout_s: float = DEFAULT_TIMEOUT_S,
) -> None:
    """Wait until a put on ``key_expr`` from ``session`` reaches a subscriber.

    A publisher is declared for the check and undeclared afterwards; its
    ``matching_status.matching`` turns true once a matching subscriber's
    declaration has reached this session.

    Parameters
    ----------
    session
        The publishing side.
    key_expr
        A concrete key the subscriber should receive.
    timeout_s
        Deadline in seconds.

    Raises
    ------
    TimeoutError
        If no matching subscriber shows up in time.
    """
    publisher = session.declare_publisher(key_expr)
    try:
        wait_until(
            # The stub says bool; zenoh 1.x returns a MatchingStatus.
            lambda: publisher.matching_status.matching,  # type: ignore[attr-defined]
            timeout_s,
            what=f"a subscriber matching {key_expr}",
        )
    finally:
        publisher.undeclare()


@contextlib.contextmanager
def open_peer_pair(
    timeout_s: float = DEFAULT_TIMEOUT_S,
) -> Iterator[tuple[zenoh.Session, zenoh.Session]]:
    """Open two connected in-process peers on loopback.

    The first peer listens on an ephemeral port; the second connects to the
    port read back with :func:`listening_endpoints`. The context is entered
    only once both list each other in ``session.info.peers_zid()``. Both
    sessions are closed on exit, even after an error.

    Parameters
    ----------
    timeout_s
        Deadline for the connection, in seconds.

    Yields
    ------
    tuple of zenoh.Session
        ``(listener, connector)``.
    """
    a = zenoh.open(loopback_config())
    try:
        b = zenoh.open(
            loopback_config(listen=None, connect=listening_endpoints(a))
        )
        try:
            wait_connected(a, b, timeout_s)
            yield a, b
        finally:
            b.close()
    finally:
        a.close()
