"""The argument parser of ``fsw-scheduler``: one function per command.

:func:`build_parser` builds the top level (``--version``, ``--log-level``)
and calls one ``add_<command>_command`` per subcommand; a new command is
one more such function (in :mod:`.files_flags` for commands on files, in
:mod:`.bus_flags` for commands on the bus) and one ``cmd_*`` handler.
"""

from __future__ import annotations

import argparse
import textwrap
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .commands import Command

    pass
from .bus_flags import (
    add_config_command,
    add_probe_command,
    add_record_command,
    add_replay_command,
    add_run_command,
)
from .files_flags import (
    add_check_command,
    add_demo_command,
    add_info_command,
    add_layout_command,
    add_plot_command,
    add_recover_command,
    add_replan_command,
    add_schemas_command,
    add_solve_command,
    add_state_command,
)
from .ros2_bridge import add_ros2_bridge_command
from .talk import add_talk_commands
from .view import add_view_command

LOG_LEVELS = ("debug", "info", "warning", "error")


DESCRIPTION = """\
On-board activity scheduler for spacecraft.

A problem file lists tasks (length, costs, feasible interval, resource
uses, preemption policy) and precedences; the scheduler places them on a
time-indexed timeline with an integer linear program (CBC by default) and
says why any task was left out.

Start here:
  fsw-scheduler demo                      the paper scenario on a live bus
  fsw-scheduler solve problem.json --gantt plan.png
  fsw-scheduler check problem.json plan.json
  fsw-scheduler run --problem resources.json --state /var/lib/fsw
                                          the bus component, resumable
  fsw-scheduler send goal goal.json --wait
                                          give a running node work
  fsw-scheduler status --follow           watch it (plan: its plan)
  fsw-scheduler view                      watch it live in Foxglove
  fsw-scheduler demo --scenario failover  two redundant nodes, killed
"""


EPILOG = """\
exit codes: 0 ok, 1 no plan (infeasible / unknown) or violations,
2 bad input (stderr names the field and the reason).
Formats: docs/formats.md describes the problem, plan, goal and bus
message formats; `fsw-scheduler schemas --out DIR` writes their JSON Schemas.
"""


def _add_verbosity(parser: argparse.ArgumentParser, default: object) -> None:
    """``-v``/``-q``, as every command line tool has them."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        default=default,
        help="say more: debug logs (--log-level debug)",
    )
    group.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        default=default,
        help="say less: warnings and errors only, no progress lines",
    )


def log_level(args: argparse.Namespace) -> str:
    """The log level the flags ask for: ``-v`` debug, ``-q`` warning,
    else ``--log-level``."""
    if getattr(args, "verbose", False):
        return "debug"
    if getattr(args, "quiet", False) and args.log_level in ("debug", "info"):
        return "warning"
    return str(args.log_level)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``fsw-scheduler`` (all subcommands)."""
    parser = argparse.ArgumentParser(
        prog="fsw-scheduler",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from ... import __version__

    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {__version__}"
    )
    parser.add_argument(
        "--log-level",
        default="info",
        choices=LOG_LEVELS,
        help="log verbosity on stderr (default: %(default)s)",
    )
    _add_verbosity(parser, argparse.SUPPRESS)
    parser.set_defaults(verbose=False, quiet=False)
    # The same flags after the command name (`solve --log-level debug`,
    # `send -q`); SUPPRESS keeps the value given before the command when
    # absent here.
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--log-level",
        default=argparse.SUPPRESS,
        choices=LOG_LEVELS,
        help="log verbosity on stderr (default: info)",
    )
    _add_verbosity(common, argparse.SUPPRESS)
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    commands.required = True

    def add(
        name: str, func: Command, help_: str, description: str = ""
    ) -> argparse.ArgumentParser:
        text = textwrap.dedent(description or help_)
        # The examples go after the flags, where --help readers look for
        # them (the epilog), as in the zenoh and rosbag2 tools.
        head, sep, examples = text.partition("\nexample")
        sub = commands.add_parser(
            name,
            help=help_,
            description=head.rstrip() + "\n",
            epilog=f"example{examples}" if sep else None,
            formatter_class=argparse.RawDescriptionHelpFormatter,
            parents=[common],
        )
        sub.set_defaults(func=func)
        return sub

    add_solve_command(add)
    add_check_command(add)
    add_replan_command(add)
    add_demo_command(add)
    add_run_command(add)
    add_talk_commands(add)
    add_view_command(add)
    add_config_command(add)
    add_probe_command(add)
    add_record_command(add)
    add_replay_command(add)
    add_ros2_bridge_command(add)
    add_recover_command(add)
    add_state_command(add)
    add_info_command(add)
    add_plot_command(add)
    add_schemas_command(add)
    add_layout_command(add)
    return parser
