"""``fsw-scheduler view``: a live, read-only Foxglove view of a scheduler.

The command opens a Zenoh session with the flags of ``run``, starts a
Foxglove WebSocket server (foxglove-sdk, the ``view`` extra) with the
journal's channels, and republishes the spacecraft's traffic on it
(:class:`fsw_scheduler.app.live_view.LiveBridge`) until Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from ...bus.session import add_zenoh_arguments
from .commands import (
    EXIT_OK,
    MissingDependency,
    add_spacecraft_flag,
    check_spacecraft,
    open_bus,
    positive_float,
)
from .stopping import stop_on_signals

if TYPE_CHECKING:
    from .files_flags import Add

__all__ = ["add_view_command"]

#: How to get the layout for this view (and for journals): it is shipped
#: in the package (a clone also has it as docs/foxglove-layout.json).
LAYOUT = "fsw-scheduler layout --out layout.json"


def _port(text: str) -> int:
    """An argparse type: a TCP port, 0 for a free one."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port") from None
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"{text} is not in 0..65535")
    return value


def add_view_command(add: Add) -> None:
    """The ``view`` command and its flags."""
    view = add(
        "view",
        _cmd_view,
        "serve a live, read-only Foxglove view of a running scheduler",
        f"""\
        Watch a running scheduler in Foxglove. The command joins the bus
        (the Zenoh flags are those of 'run'), subscribes to everything the
        spacecraft's keys carry (fsw/<sc>/**), asks the scheduler for its
        current plan, status and profiles, and serves it all over the
        Foxglove WebSocket protocol: one channel per key, with the JSON
        Schemas and names of the journal, so the layout (written by
        {LAYOUT}) works for the live view and for a
        recording alike. It also derives the journal's level checks
        (scheduler/levels) and log (scheduler/log, foxglove.Log). A window
        opened at any time gets the current plan, status and profiles at
        once.

        It only subscribes and queries, never publishes: in the secure
        profile it runs with the monitor certificate. It listens on
        127.0.0.1 unless --host says otherwise; --port 0 picks a free port.
        On start it prints the ws:// address and the links that open it.
        Ctrl-C or SIGTERM stop it (exit 0).

        To open it in Foxglove: follow the printed app.foxglove.dev link,
        or in Foxglove choose "Open connection", "Foxglove WebSocket" and
        paste the ws:// address; then "Layouts", "Import from file", the
        file {LAYOUT} writes. Needs {_hint()}.

        examples:
          fsw-scheduler view
          fsw-scheduler view --port 0 --spacecraft sat2 -e tcp/10.0.0.1:7447
          fsw-scheduler view --config monitor.json5 --host 0.0.0.0
        """,
    )
    add_spacecraft_flag(view)
    view.add_argument(
        "--host",
        default="127.0.0.1",
        help="address the WebSocket server binds (default: %(default)s, "
        "this computer only)",
    )
    view.add_argument(
        "--port",
        type=_port,
        default=8765,
        help="its TCP port, 0 for a free one (default: %(default)s, "
        "Foxglove's)",
    )
    view.add_argument(
        "--timeout",
        type=positive_float,
        default=3.0,
        metavar="S",
        help="seconds to wait for each of the scheduler's answers at start "
        "(default: %(default)s); without one the view fills as messages "
        "arrive",
    )
    add_zenoh_arguments(view)


def _hint() -> str:
    from ...view.live import LIVE_INSTALL_HINT

    return LIVE_INSTALL_HINT


def _cmd_view(args: argparse.Namespace) -> int:
    import threading

    from ...bus.session import zenoh_config
    from ...errors import BusError
    from ...journal.channels import live_channels
    from ...view.live import LiveServer, have_foxglove
    from ...wire import topics as keys
    from ..live_view import LiveBridge

    check_spacecraft(args.spacecraft)
    if not have_foxglove():
        raise MissingDependency(
            f"view needs foxglove-sdk, which is not installed: {_hint()}"
        )
    settings = zenoh_config(args)
    stop = threading.Event()
    stop_on_signals(stop)
    bridge: LiveBridge | None = None
    with open_bus(settings) as session:
        try:
            server = LiveServer(
                live_channels(args.spacecraft),
                host=args.host,
                port=args.port,
                no_replay=[keys.Topics(args.spacecraft).key(keys.LOG)],
                on_subscribe=lambda: bridge.poke() if bridge else None,
            )
        except RuntimeError as error:
            raise BusError(
                f"cannot serve on {args.host}:{args.port}: {error}"
            ) from None
        with server, LiveBridge(session, server, args.spacecraft) as bridge:
            answered = bridge.start(args.timeout)
            where = keys.Topics(args.spacecraft).everything
            print(
                f"fsw-scheduler view: {where} on {server.url}\n"
                f"  open in the browser: {server.app_url()}\n"
                f"  open in the app:     {server.open_url}\n"
                f"  layout:              {LAYOUT}, then Layouts, Import\n"
                f"  scheduler: "
                + (
                    "answered " + ", ".join(answered)
                    if answered
                    else "no answer yet; showing what arrives"
                ),
                flush=True,
            )
            bridge.run(stop)
    print("fsw-scheduler view: stopped", file=sys.stderr, flush=True)
    return EXIT_OK
