"""``fsw-scheduler ros2-bridge``: the scheduler seen from ROS 2 tools.

The command opens a Zenoh session with the flags of ``run`` and runs a
:class:`~fsw_scheduler.bus.ros2.Ros2Bridge` until Ctrl-C or SIGTERM. It
needs the ``ros2`` extra (zenoh-ros2-sdk); without it, it exits 2 with the
install command.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from ...bus.session import add_zenoh_arguments
from .commands import (
    EXIT_OK,
    MissingDependency,
    add_spacecraft_flag,
    check_spacecraft,
    number_type,
    open_bus,
)
from .stopping import stop_on_signals

if TYPE_CHECKING:
    import argparse

    from .files_flags import Add

log = logging.getLogger("fsw_scheduler")

#: What to type when the ``ros2`` extra is missing.
ROS2_INSTALL_HINT = "pip install 'fsw-scheduler[ros2]'"
#: Top-level packages of the ``ros2`` extra the bridge imports.
_EXTRA_PACKAGES = ("zenoh_ros2_sdk", "rosbags")


def add_ros2_bridge_command(add: Add) -> None:
    """The ``ros2-bridge`` command and its flags."""
    bridge = add(
        "ros2-bridge",
        _cmd_ros2_bridge,
        "show the plan, status and dispatches to ROS 2 tools (rmw_zenoh)",
        """\
        Republish what the scheduler publishes as ROS 2 topics, the way
        rmw_zenoh (the Zenoh middleware of ROS 2 and Space ROS) carries
        them, so that `ros2 topic list` and `ros2 topic echo` see them.
        Each message is a std_msgs/msg/String whose data is the
        scheduler's JSON, unchanged:

          /fsw/<sc>/scheduler/plan         fsw/<sc>/scheduler/plan
          /fsw/<sc>/scheduler/status       fsw/<sc>/scheduler/status
          /fsw/<sc>/scheduler/dispatches   fsw/<sc>/scheduler/dispatch/*

        (characters of <sc> other than letters, digits and _ become _ in
        the ROS 2 names). The bridge only reads the scheduler's keys and
        never publishes on them; topics are volatile (a subscriber sees
        the messages published after it joined: `fsw-scheduler plan`
        prints the current plan). The message definition is shipped with
        the package: nothing is fetched at run time. Stop it with Ctrl-C
        or SIGTERM. Needs the ros2 extra: pip install 'fsw-scheduler[ros2]'.

        examples:
          fsw-scheduler ros2-bridge -m client -e tcp/127.0.0.1:7447
          fsw-scheduler ros2-bridge --spacecraft sat2 --domain-id 3 \\
              -c deploy/monitor.json5

        then, on a ROS 2 computer with rmw_zenoh and the same router:
          export RMW_IMPLEMENTATION=rmw_zenoh_cpp
          ros2 topic list
          ros2 topic echo /fsw/sat1/scheduler/plan
          ros2 topic echo /fsw/sat1/scheduler/dispatches
        """,
    )
    add_spacecraft_flag(bridge)
    bridge.add_argument(
        "--domain-id",
        type=number_type(int, minimum=0, strict=False),
        metavar="N",
        help="the ROS 2 domain (default: ROS_DOMAIN_ID, else 0)",
    )
    add_zenoh_arguments(bridge)


def _cmd_ros2_bridge(args: argparse.Namespace) -> int:
    import threading

    from ...bus.session import zenoh_config

    check_spacecraft(args.spacecraft)
    try:
        from ...bus.ros2 import Ros2Bridge
    except ImportError as error:
        if (error.name or "").split(".")[0] not in _EXTRA_PACKAGES:
            raise
        raise MissingDependency(
            "ros2-bridge needs zenoh-ros2-sdk, which is not installed: "
            f"{ROS2_INSTALL_HINT}"
        ) from None
    stop = threading.Event()
    stop_on_signals(stop)
    with (
        open_bus(zenoh_config(args)) as session,
        Ros2Bridge(
            session, args.spacecraft, domain_id=args.domain_id
        ) as bridge,
    ):
        log.info(
            "ros2-bridge up: domain %d, %s (Ctrl-C to stop)",
            bridge.domain_id,
            ", ".join(t.ros_topic for t in bridge.topics),
        )
        stats = bridge.run(stop)
    log.info(
        "ros2-bridge stopped: %s forwarded",
        ", ".join(
            f"{stats.forwarded.get(t.leaf, 0)} {t.leaf}" for t in bridge.topics
        ),
    )
    return EXIT_OK
