"""Flags of the commands on files: solve, check, replan, demo, plot, ...

Also info, recover and schemas.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

from ...view.pages import ROWS_PER_PAGE
from .commands import (
    cmd_check,
    cmd_demo,
    cmd_examples,
    cmd_info,
    cmd_layout,
    cmd_plot,
    cmd_recover,
    cmd_replan,
    cmd_schemas,
    cmd_solve,
    cmd_state,
    non_negative_float,
    positive_float,
)
from .run_flags import RUN_FLAGS


def _add_solver_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--solver",
        choices=("cbc", "highs"),
        default="cbc",
        help="MILP solver (default: %(default)s)",
    )
    parser.add_argument(
        "--time-limit",
        type=positive_float,
        metavar="S",
        help="seconds (> 0) for the whole solve, start plan, model and "
        "explanations included (the plan is out within about 0.5 s of "
        "it; progress is logged every few seconds); at the limit the best "
        "plan is returned with status 'feasible' (default: none)",
    )
    parser.add_argument(
        "--no-explain",
        dest="explain",
        action="store_false",
        help="skip the extra solves that say why tasks were left out",
    )


Add = Callable[..., argparse.ArgumentParser]


#: How --gantt names its pages, in its help.
_PAGES = (
    f" (over {ROWS_PER_PAGE} task rows, as pages: NAME.png gives "
    "NAME-1.png, NAME-2.png, ...)"
)


def add_solve_command(add: Add) -> None:
    """The ``solve`` command and its flags."""
    solve = add(
        "solve",
        cmd_solve,
        "solve a problem file and print the plan JSON",
        """\
        Solve a problem file (format: docs/formats.md, "Problem, plan and
        goal files"; schema: `fsw-scheduler schemas`) and print the plan JSON
        (status, objective, activities, unscheduled, why, solver stats).

        example:
          fsw-scheduler solve problem.json --out plan.json --gantt plan.png
        """,
    )
    solve.add_argument("problem", help="problem JSON file ('-' for stdin)")
    solve.add_argument("--out", metavar="PLAN.json", help="write plan here")
    solve.add_argument(
        "--gantt",
        metavar="PNG",
        help="also draw the plan: task bars plus resource profiles" + _PAGES,
    )
    _add_solver_arguments(solve)


def add_check_command(add: Add) -> None:
    """The ``check`` command and its flags."""
    check = add(
        "check",
        cmd_check,
        "check a plan against a problem, independently of the solver",
        """\
        Walk the plan time unit by time unit and report every violated
        constraint by name; recompute the objective. Shares no code with
        the ILP.

        example:
          fsw-scheduler check problem.json plan.json
        """,
    )
    check.add_argument("problem", help="problem JSON file")
    check.add_argument("plan", help="plan JSON file")


def add_replan_command(add: Add) -> None:
    """The ``replan`` command and its flags."""
    replan = add(
        "replan",
        cmd_replan,
        "apply a goal or event to a running plan at time --now",
        """\
        Apply a goal (a goal document) or an event to a running plan at
        time T, by the paper's online rescheduling rules: finished tasks
        leave, running tasks follow their preemption policy, obsolete tasks
        and their tight followers go, lax links to them are dropped. The new
        plan covers [T, T + horizon) and is printed on stdout; the diff
        (kept, moved, added, removed with the rule that removed each) goes
        to stderr.

        An event is {"event": "activity_failed", "task": ..., "at": T} or
        {"event": "levels", "levels": {"battery": 5.0}, "at": T}.

        --commit-window, --stability and --move-cost are run's settings,
        with the same meaning: what starts within the window keeps its
        start, and moving a planned activity is priced.

        example:
          fsw-scheduler replan table1.json plan.json goal.json --now 15
        """,
    )
    replan.add_argument("problem", help="the running problem JSON")
    replan.add_argument("plan", help="its plan JSON")
    replan.add_argument("change", help="goal or event JSON")
    replan.add_argument(
        "--now",
        type=int,
        required=True,
        metavar="T",
        help="time unit of the replan",
    )
    replan.add_argument("--out", metavar="PLAN.json", help="write plan here")
    replan.add_argument(
        "--problem-out",
        metavar="PROBLEM.json",
        help="also write the new problem (to chain replans or check)",
    )
    replan.add_argument(
        "--gantt",
        metavar="PNG",
        help="draw the new plan with a 'now' line" + _PAGES,
    )
    _add_solver_arguments(replan)
    # The flags of ``run``, with its defaults (the paper's replan).
    defaults = {"commit_window": 0, "stability": "off", "move_cost": 5}
    for flag in RUN_FLAGS:
        if flag.setting in defaults:
            replan.add_argument(
                flag.name,
                **{**flag.options, "default": defaults[flag.setting]},
            )


def add_demo_command(add: Add) -> None:
    """The ``demo`` command and its flags."""
    demo = add(
        "demo",
        cmd_demo,
        "the paper scenario end to end on an in-process bus",
        """\
        Run the paper's scenario on an in-process Zenoh bus: the scheduler,
        a simulated executor that runs dispatched activities and reports
        battery levels, the Table 1 problem at t=0 and the Table 2 goal at
        t=15, on a fast clock. Prints a live timeline, then writes the MCAP
        journal, one Gantt picture per plan and the final timeline to --out,
        and replays the journal to prove the decisions are reproduced.

        examples:
          fsw-scheduler demo
          fsw-scheduler demo --scenario failure --out out/failure --quiet
        """,
    )
    demo.add_argument(
        "--out", default="out/demo", help="output folder (%(default)s)"
    )
    demo.add_argument(
        "--scenario",
        choices=("paper", "failure", "failover", "orbit"),
        default="paper",
        help="paper: Table 1 then the Table 2 goal; failure: also a failed "
        "activity and a draining battery; failover: the paper scenario on "
        "two redundant schedulers (separate processes) that are killed "
        "and resume or take over; orbit: an Earth-observation day with "
        "eclipses, passes and HF/LF alternatives, and a forecast of a "
        "longer eclipse (default: %(default)s)",
    )
    demo.add_argument("--spacecraft", default="sat1", help="key prefix id")
    demo.add_argument(
        "--no-verify", action="store_true", help="skip the replay check"
    )
    demo.add_argument(
        "--time-unit",
        type=non_negative_float,
        default=0.05,
        metavar="S",
        help="wall seconds per time unit, at least (default %(default)s)",
    )


def add_recover_command(add: Add) -> None:
    """The ``recover`` command and its flags."""
    recov = add(
        "recover",
        cmd_recover,
        "rewrite a truncated MCAP file into a readable one",
        """\
        Read every complete chunk and message of an MCAP file whose writer
        was killed (no footer, half a chunk at the end) and write them into
        a new, finished file with its index. Prints the messages kept per
        channel.

        example:
          fsw-scheduler recover killed.mcap --out session.mcap
        """,
    )
    recov.add_argument("file", help="the truncated MCAP file")
    recov.add_argument(
        "--out",
        required=True,
        metavar="FILE.mcap",
        help="where to write the finished file",
    )


def add_state_command(add: Add) -> None:
    """The ``state`` command and its flags."""
    state = add(
        "state",
        cmd_state,
        "say what is intact in a state folder (run --state DIR)",
        """\
        Walk every journal file of a state folder record by record: record
        sizes bounded, every chunk decompressed and its CRC checked, the
        summary checked against its footer. Prints one line per file:
        intact (finished, or truncated by a crash: the next start finishes
        it) or DAMAGED at a byte offset, with the messages intact before
        it. Exit 0 when every file is intact, 2 when one is damaged (then
        'run --state' refuses the folder: move the damaged files aside).

        example:
          fsw-scheduler state check /var/lib/fsw-scheduler
        """,
    )
    state.add_argument("action", choices=["check"], help="what to do")
    state.add_argument("folder", metavar="DIR", help="the state folder")


def add_info_command(add: Add) -> None:
    """The ``info`` command and its flags."""
    inf = add(
        "info",
        cmd_info,
        "summarise an MCAP file",
        """\
        Print the message count, time span and every channel with its
        message count and schema (also for truncated files).

        Also lists the file's metadata records and attachments.

        examples:
          fsw-scheduler info session.mcap
          fsw-scheduler info session.mcap --json
        """,
    )
    inf.add_argument("file", help="an MCAP file")
    inf.add_argument(
        "--json",
        action="store_true",
        help="print JSON instead: file, finished, messages, start/end (ns "
        "and UTC), duration_s, channels (topic, messages, schema, "
        "encoding), metadata, attachments",
    )


def add_plot_command(add: Add) -> None:
    """The ``plot`` command and its flags."""
    plo = add(
        "plot",
        cmd_plot,
        "draw every plan of a recorded session, and levels vs measured",
        """\
        Read a scheduler journal (run --record, demo) and draw, into
        --out, one Gantt picture per plan (plan-<id>.png: what had run
        before, the tasks that replan removed with the rule, one lane per
        binary resource showing who holds it, the resource profiles and
        the measured levels while the plan was in force) and levels.png:
        every consumable over the session, as each plan predicted it
        against the measured samples.

        examples:
          fsw-scheduler plot out/demo/session.mcap --out out/pictures
          fsw-scheduler plot replay/failure.mcap --out failure-pictures
          fsw-scheduler plot session.mcap --out pics --attach-to shared.mcap
        """,
    )
    plo.add_argument("file", help="a scheduler journal (MCAP)")
    plo.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="folder for the PNG files (created if missing)",
    )
    plo.add_argument(
        "--attach-to",
        metavar="COPY.mcap",
        help="also write a copy of the journal with the pictures attached "
        "(the journal itself is left as it is)",
    )


def add_layout_command(add: Add) -> None:
    """The ``layout`` and ``examples`` commands and their flags."""
    lay = add(
        "layout",
        cmd_layout,
        "write the Foxglove layout for journals and the live view",
        """\
        Write the Foxglove layout shipped with this version (the
        project's docs/foxglove-layout.json): import it in Foxglove with
        Layouts, Import from file. It opens an MCAP journal and the live
        view (fsw-scheduler view) alike, for any task names. Without
        --out, the layout goes to stdout.

        example:
          fsw-scheduler layout --out fsw-layout.json
        """,
    )
    lay.add_argument(
        "--out", metavar="FILE", help="file to write (default: stdout)"
    )
    exa = add(
        "examples",
        cmd_examples,
        "write the example problem, goal and settings files",
        """\
        Write the examples shipped with this version (the project's
        examples/ folder): resources.json and goal.json for the README's
        session on the bus, problem.json, full-battery.json and the node's
        settings, scheduler.toml.

        example:
          fsw-scheduler examples --out examples/
        """,
    )
    exa.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="folder to write into (created if missing)",
    )


def add_schemas_command(add: Add) -> None:
    """The ``schemas`` command and its flags."""
    sch = add(
        "schemas",
        cmd_schemas,
        "write the JSON Schema of every message and file format",
        """\
        Write one JSON Schema per message kind (problem, plan, goal, clock,
        activity report, resource level, dispatch, status, solve record,
        node info, profiles, level check) into a folder, named
        <kind>.schema.json. They are
        generated from the message types of the installed version, the
        same files as the project's schemas/ folder.

        example:
          fsw-scheduler schemas --out schemas/
        """,
    )
    sch.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="folder to write into (created if missing)",
    )
