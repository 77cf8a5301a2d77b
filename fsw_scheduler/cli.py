"""The ``fsw-scheduler`` command line.

Each subcommand is one ``_cmd_*`` function taking the parsed arguments and
returning the exit code; ``main`` only parses and dispatches. Exit codes
follow CONTRACT section 4: 0 success, 1 infeasible / unknown / violations,
2 bad input (the message on stderr names the field).
"""

from __future__ import annotations

import argparse
import logging
import sys
import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path

import msgspec
from mcap.exceptions import McapError

from .errors import FieldIssue, InputError, SchedulerError
from .model import Problem, decode_problem, decode_strict
from .solution import Plan

log = logging.getLogger("fsw_scheduler")

EXIT_OK, EXIT_NO_PLAN, EXIT_BAD_INPUT = 0, 1, 2

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
"""

EPILOG = """\
exit codes: 0 ok, 1 no plan (infeasible / unknown) or violations,
2 bad input (stderr names the field and the reason).
Formats: see the README (problem, plan, goal and bus message schemas are
in schemas/).
"""


def _read_bytes(path: str) -> bytes:
    if path == "-":
        return sys.stdin.buffer.read()
    try:
        return Path(path).read_bytes()
    except OSError as error:
        raise InputError(
            [FieldIssue("", f"cannot read {path}: {error.strerror}")], "file"
        ) from None


def load_problem(path: str) -> Problem:
    """Read and validate a problem file (``-`` for stdin)."""
    return decode_problem(_read_bytes(path))


def load_plan(path: str) -> Plan:
    """Read a plan file (``-`` for stdin)."""
    return decode_strict(_read_bytes(path), Plan, "plan")


def _write_json(value: object, out: str | None) -> None:
    text = msgspec.json.format(msgspec.json.encode(value), indent=2)
    if out:
        Path(out).write_bytes(text + b"\n")
        log.info("wrote %s", out)
    else:
        sys.stdout.buffer.write(text + b"\n")
        sys.stdout.flush()


def _prog() -> str:
    """How the user can run this command again (e.g. .venv/bin/...)."""
    launched = Path(sys.argv[0])
    if launched.name == "fsw-scheduler" and launched.is_file():
        try:
            return str(launched.resolve().relative_to(Path.cwd()))
        except ValueError:
            return str(launched)
    return "fsw-scheduler"


def _summary(plan: Plan) -> str:
    objective = plan.objective
    parts = [f"status {plan.status.value}"]
    if objective is not None:
        parts.append(
            f"unscheduled cost {objective.unscheduled_cost}, "
            f"delay cost {objective.delay_cost}, total {objective.total}"
        )
    parts.append(
        f"{len(plan.activities)} scheduled, {len(plan.unscheduled)} left out"
    )
    if plan.stats is not None:
        parts.append(f"{plan.stats.wall_s * 1000:.0f} ms")
    return "; ".join(parts)


# -- solve ------------------------------------------------------------------


def _add_solver_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--solver",
        choices=("cbc", "highs"),
        default="cbc",
        help="MILP solver (default: %(default)s)",
    )
    parser.add_argument(
        "--time-limit",
        type=float,
        metavar="S",
        help="solver time limit in seconds; at the limit the best plan is "
        "returned with status 'feasible' (default: none)",
    )
    parser.add_argument(
        "--no-explain",
        dest="explain",
        action="store_false",
        help="skip the extra solves that say why tasks were left out",
    )


def _cmd_solve(args: argparse.Namespace) -> int:
    from .solve import solve

    problem = load_problem(args.problem)
    log.info(
        "solving %d tasks over [%d, %d) with %s",
        problem.num_tasks,
        problem.start,
        problem.end,
        args.solver,
    )
    plan = solve(
        problem,
        args.solver,
        time_limit=args.time_limit,
        explain=args.explain,
    )
    _write_json(plan, args.out)
    log.info("%s", _summary(plan))
    for blocker in plan.why:
        log.info("  %s: %s (%s)", blocker.task, blocker.cause, blocker.detail)
    if args.gantt and plan.status.has_plan:
        from .plot import gantt

        gantt(problem, plan, Path(args.gantt))
        log.info("wrote %s", args.gantt)
    return EXIT_OK if plan.status.has_plan else EXIT_NO_PLAN


# -- check ------------------------------------------------------------------


def _cmd_check(args: argparse.Namespace) -> int:
    from .check import check_plan, format_report

    problem = load_problem(args.problem)
    plan = load_plan(args.plan)
    report = check_plan(problem, plan)
    print(format_report(report))
    return EXIT_OK if report.ok else EXIT_NO_PLAN


# -- replan -----------------------------------------------------------------


def _cmd_replan(args: argparse.Namespace) -> int:
    from .reschedule import decode_change, format_diff, replan_files

    problem = load_problem(args.problem)
    plan = load_plan(args.plan)
    change = decode_change(_read_bytes(args.change))
    new_problem, new_plan, diff = replan_files(
        problem,
        plan,
        change,
        args.now,
        solver=args.solver,
        time_limit=args.time_limit,
    )
    if args.problem_out:
        _write_json(new_problem, args.problem_out)
    _write_json(new_plan, args.out)
    log.info("%s", _summary(new_plan))
    print(format_diff(diff, new_plan), file=sys.stderr)
    if args.gantt and new_plan.status.has_plan:
        from .plot import gantt

        gantt(new_problem, new_plan, Path(args.gantt), now=args.now)
        log.info("wrote %s", args.gantt)
    return EXIT_OK if new_plan.status.has_plan else EXIT_NO_PLAN


# -- demo --------------------------------------------------------------------


def _cmd_demo(args: argparse.Namespace) -> int:
    from .demo import SCENARIOS, run_demo

    out = Path(args.out)
    log.info("demo (%s scenario): output in %s", args.scenario, out)
    result = run_demo(
        out,
        scenario=SCENARIOS[args.scenario](),
        spacecraft=_checked_spacecraft(args.spacecraft),
        verify=not args.no_verify,
        quiet=args.quiet,
        time_unit=args.time_unit,
    )
    final = result.plans[-1] if result.plans else None
    print()
    if final is not None:
        text = out / f"plan-{final.plan_id}.txt"
        if text.exists():
            print(f"final plan {final.plan_id}:")
            print(text.read_text())
    print("executed:")
    for activity in sorted(result.executed, key=lambda a: (a.start, a.task)):
        print(
            f"  {activity.task:<20} [{activity.start:>3}, {activity.end:>3})"
        )
    print(f"\njournal (MCAP): {result.journal}")
    for picture in result.pictures:
        print(f"picture: {picture}")
    print(f"replay it:  {_prog()} replay {result.journal} --verify")
    if result.verified is False:
        return EXIT_NO_PLAN
    return EXIT_OK


# -- run ---------------------------------------------------------------------


def _checked_spacecraft(spacecraft: str) -> str:
    _check_spacecraft(spacecraft)
    return spacecraft


def _check_spacecraft(spacecraft: str | None) -> None:
    """Refuse a spacecraft id that is not a key-safe id (exit 2)."""
    from .model import id_issue

    reason = None if spacecraft is None else id_issue(spacecraft)
    if reason is not None:
        raise InputError(
            [FieldIssue("--spacecraft", f"the spacecraft id {reason}")],
            "arguments",
        )



def _cmd_run(args: argparse.Namespace) -> int:
    import signal
    import threading

    import zenoh

    from .bus.node import SchedulerNode
    from .bus.session import toml_config_file, zenoh_config
    from .config import load_config
    from .messages import schema_lookup
    from .model import Problem
    from .recording import Recorder

    try:
        config = load_config(toml_config_file(args)).replace(
            spacecraft=args.spacecraft,
            clock=args.clock,
            time_unit=args.time_unit,
            solver=args.solver,
            time_limit=args.time_limit,
            horizon=args.horizon,
            response_deadline=args.response_deadline,
            tasks_per_goal=args.tasks_per_goal,
            live_tasks=args.live_tasks,
            goals_waiting=args.goals_waiting,
            max_clock_step=args.max_clock_step,
            clock_stall=args.clock_stall,
        )
    except ValueError as error:  # a bad value given as a flag
        raise InputError([FieldIssue("", str(error))], "arguments") from None
    if args.problem:
        problem = decode_problem(_read_bytes(args.problem), allow_empty=True)
    else:
        if config.horizon is None:
            raise InputError(
                [FieldIssue("horizon", "give --problem or --horizon")],
                "arguments",
            )
        problem = Problem(horizon=config.horizon, tasks=())
    journal = None
    if args.record:
        journal = Recorder(
            args.record, schemas=schema_lookup(config.spacecraft)
        )
    stop = threading.Event()

    def on_signal(signum: int, _frame: object) -> None:
        log.info("signal %d: stopping", signum)
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    with zenoh.open(zenoh_config(args)) as session:
        node = SchedulerNode(session, problem, config, journal=journal)
        node.start()
        try:
            # The node stops itself when its loop cannot go on.
            while not stop.is_set() and not node.wait_stopped(0.2):
                pass
        finally:
            node.close()
    if node.failed is not None:
        print(f"fsw-scheduler: error: {node.failed}", file=sys.stderr)
        return EXIT_NO_PLAN
    return EXIT_OK


# -- record / replay / recover / info ----------------------------------------


def _cmd_record(args: argparse.Namespace) -> int:
    import signal
    import threading

    import zenoh

    from .bus.record import record
    from .bus.session import zenoh_config
    from .bus.topics import Topics
    from .messages import schema_lookup
    from .recording import Recorder

    _check_spacecraft(args.spacecraft)
    key = args.key or Topics(args.spacecraft).everything
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    recorder = Recorder(
        args.out,
        compression=args.compression,
        split_size=args.split_size,
        split_duration_ns=(
            int(args.split_duration * 1e9) if args.split_duration else None
        ),
        flush_interval_ns=int(args.flush_interval * 1e9),
        schemas=schema_lookup(args.spacecraft),
    )
    with zenoh.open(zenoh_config(args)) as session, recorder:
        log.info("recording %s to %s (Ctrl-C to stop)", key, args.out)
        stats = record(session, key, recorder, stop)
    log.info(
        "recorded %d messages on %d keys into %s",
        stats.written,
        len(stats.by_key),
        ", ".join(map(str, recorder.paths)),
    )
    return EXIT_OK


def _cmd_replay(args: argparse.Namespace) -> int:
    if args.verify:
        from .replay import verify

        report = verify(args.files, progress=lambda line: log.info("%s", line))
        print(report.summary())
        return EXIT_OK if report.identical else EXIT_NO_PLAN
    import zenoh

    from .bus.record import replay
    from .bus.session import zenoh_config

    with zenoh.open(zenoh_config(args)) as session:
        if args.wait_matching:
            from .bus.session import wait_matching

            key = args.wait_key or "fsw/**"
            log.info("waiting for a subscriber on %s", key)
            wait_matching(session, key, args.wait_matching)
        count = replay(
            session,
            args.files,
            rate=args.rate,
            burst=args.burst,
            start_offset_s=args.start_offset,
            until_s=args.until,
            loop=args.loop,
            include=args.include,
            exclude=args.exclude,
        )
    log.info("published %d messages", count)
    return EXIT_OK


def _cmd_recover(args: argparse.Namespace) -> int:
    from .recording import recover

    kept = recover(args.file, args.out)
    print(f"recovered {sum(kept.values())} messages into {args.out}")
    for topic, count in sorted(kept.items()):
        print(f"  {count:>7}  {topic}")
    return EXIT_OK


def _cmd_info(args: argparse.Namespace) -> int:
    from .recording import format_info, info

    print(format_info(info(args.file)))
    return EXIT_OK


# -- parser -----------------------------------------------------------------

Command = Callable[[argparse.Namespace], int]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``fsw-scheduler`` (all subcommands)."""
    parser = argparse.ArgumentParser(
        prog="fsw-scheduler",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    from . import __version__

    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {__version__}"
    )
    parser.add_argument(
        "--log-level",
        default="info",
        choices=("debug", "info", "warning", "error"),
        help="log verbosity on stderr (default: %(default)s)",
    )
    commands = parser.add_subparsers(dest="command", metavar="COMMAND")
    commands.required = True

    def add(
        name: str, func: Command, help_: str, description: str = ""
    ) -> argparse.ArgumentParser:
        sub = commands.add_parser(
            name,
            help=help_,
            description=textwrap.dedent(description or help_),
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        sub.set_defaults(func=func)
        return sub

    solve = add(
        "solve",
        _cmd_solve,
        "solve a problem file and print the plan JSON",
        """\
        Solve a problem file (CONTRACT section 1) and print the plan JSON
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
        help="also draw the plan: task bars plus resource profiles",
    )
    _add_solver_arguments(solve)

    check = add(
        "check",
        _cmd_check,
        "check a plan against a problem, independently of the solver",
        """\
        Walk the plan time unit by time unit and report every violated
        constraint by name; recompute the objective. Shares no code with
        the ILP.
        """,
    )
    check.add_argument("problem", help="problem JSON file")
    check.add_argument("plan", help="plan JSON file")

    replan = add(
        "replan",
        _cmd_replan,
        "apply a goal or event to a running plan at time --now",
        """\
        Apply a goal (CONTRACT section 3) or an event to a running plan at
        time T, by the paper's online rescheduling rules: finished tasks
        leave, running tasks follow their preemption policy, obsolete tasks
        and their tight followers go, lax links to them are dropped. The new
        plan covers [T, T + horizon) and is printed on stdout; the diff
        (kept, moved, added, removed with the rule that removed each) goes
        to stderr.

        An event is {"event": "activity_failed", "task": ..., "at": T} or
        {"event": "levels", "levels": {"battery": 5.0}, "at": T}.

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
        "--gantt", metavar="PNG", help="draw the new plan with a 'now' line"
    )
    _add_solver_arguments(replan)

    demo = add(
        "demo",
        _cmd_demo,
        "the paper scenario end to end on an in-process bus",
        """\
        Run the paper's scenario on an in-process Zenoh bus: the scheduler,
        a simulated executor that runs dispatched activities and reports
        battery levels, the Table 1 problem at t=0 and the Table 2 goal at
        t=15, on a fast clock. Prints a live timeline, then writes the MCAP
        journal, one Gantt picture per plan and the final timeline to --out,
        and replays the journal to prove the decisions are reproduced.
        """,
    )
    demo.add_argument(
        "--out", default="out/demo", help="output folder (%(default)s)"
    )
    demo.add_argument(
        "--scenario",
        choices=("paper", "failure"),
        default="paper",
        help="paper: Table 1 then the Table 2 goal; failure: also a failed "
        "activity and a draining battery (default: %(default)s)",
    )
    demo.add_argument("--spacecraft", default="sat1", help="key prefix id")
    demo.add_argument(
        "--no-verify", action="store_true", help="skip the replay check"
    )
    demo.add_argument("--quiet", action="store_true", help="no live timeline")
    demo.add_argument(
        "--time-unit",
        type=float,
        default=0.05,
        metavar="S",
        help="wall seconds per time unit, at least (default %(default)s)",
    )

    from .bus.session import add_zenoh_arguments

    run = add(
        "run",
        _cmd_run,
        "run the scheduler as a component on a Zenoh bus",
        """\
        Run the scheduler on the bus. It listens for goals on
        fsw/<sc>/scheduler/goals and telemetry on fsw/<sc>/telemetry/**,
        publishes the plan (also a queryable), a dispatch per activity when
        its start time comes, and status; it holds a liveliness token while
        it runs. Stop it with Ctrl-C or SIGTERM.

        examples:
          fsw-scheduler run --problem resources.json --clock wall --time-unit 1
          fsw-scheduler run --problem p.json --clock bus -e tcp/10.0.0.2:7447
          fsw-scheduler run --config scheduler.toml --record session.mcap
        """,
    )
    run.add_argument(
        "--problem",
        metavar="PROBLEM.json",
        help="resources, horizon length and any initial tasks",
    )
    run.add_argument("--spacecraft", help="key prefix id (default sat1)")
    run.add_argument(
        "--clock",
        choices=("bus", "wall"),
        help="time from fsw/<sc>/clock, or the node's own clock",
    )
    run.add_argument(
        "--time-unit",
        type=float,
        metavar="S",
        help="seconds per time unit with --clock wall",
    )
    run.add_argument("--horizon", type=int, help="horizon length override")
    run.add_argument(
        "--record",
        metavar="FILE.mcap",
        help="journal every input and output (for replay --verify)",
    )
    run.add_argument("--solver", choices=("cbc", "highs"), help="MILP solver")
    run.add_argument(
        "--time-limit", type=float, metavar="S", help="seconds per solve"
    )
    limits = run.add_argument_group(
        "limits",
        "What a sender gets beyond each limit is in the README "
        "(robustness); the same settings exist in the TOML file.",
    )
    limits.add_argument(
        "--response-deadline",
        type=float,
        metavar="S",
        help="seconds from a goal's arrival to its plan; the solve gets "
        "what is left (default 15)",
    )
    limits.add_argument(
        "--tasks-per-goal",
        type=int,
        metavar="N",
        help="a goal with more tasks is rejected (default 100)",
    )
    limits.add_argument(
        "--live-tasks",
        type=int,
        metavar="N",
        help="a goal that would make the plan hold more live tasks is "
        "rejected (default 300)",
    )
    limits.add_argument(
        "--goals-waiting",
        type=int,
        metavar="N",
        help="goals queued behind a solve; more are rejected 'busy' "
        "(default 64)",
    )
    limits.add_argument(
        "--max-clock-step",
        type=int,
        metavar="UNITS",
        help="largest forward step of one bus clock message; a bigger one "
        "is rejected (default 100)",
    )
    limits.add_argument(
        "--clock-stall",
        type=float,
        metavar="S",
        help="seconds without a bus clock message before the status turns "
        "degraded (default 30)",
    )
    add_zenoh_arguments(run)

    rec = add(
        "record",
        _cmd_record,
        "record bus traffic to MCAP",
        """\
        Subscribe to a key expression (default fsw/<sc>/**) and write each
        sample as an MCAP message: one channel per key, JSON encoding with
        the JSON Schema of the key where there is one. Small chunks and a
        periodic flush keep a killed recorder's file recoverable.
        """,
    )
    rec.add_argument("--out", required=True, metavar="FILE.mcap")
    rec.add_argument("--key", help="key expression (default fsw/<sc>/**)")
    rec.add_argument("--spacecraft", default="sat1")
    rec.add_argument(
        "--compression", choices=("zstd", "lz4", "none"), default="zstd"
    )
    rec.add_argument("--split-size", type=int, metavar="BYTES")
    rec.add_argument("--split-duration", type=float, metavar="S")
    rec.add_argument(
        "--flush-interval",
        type=float,
        default=1.0,
        metavar="S",
        help="most a crash can lose (default %(default)s s)",
    )
    add_zenoh_arguments(rec)

    rep = add(
        "replay",
        _cmd_replay,
        "publish a recording back on the bus, or --verify it",
        """\
        Publish recorded messages back on the bus in log-time order, or with
        --verify re-run a scheduler journal through a fresh scheduler and
        compare every plan, dispatch and status with the recording (exit 0
        if identical, 1 with the first divergence otherwise).
        """,
    )
    rep.add_argument("files", nargs="+", metavar="FILE.mcap")
    rep.add_argument(
        "--verify",
        action="store_true",
        help="replay through a fresh scheduler and compare decisions",
    )
    rep.add_argument("--rate", type=float, default=1.0)
    rep.add_argument(
        "--burst", action="store_true", help="as fast as possible, in order"
    )
    rep.add_argument("--start-offset", type=float, default=0.0, metavar="S")
    rep.add_argument("--until", type=float, metavar="S")
    rep.add_argument("--loop", action="store_true")
    rep.add_argument(
        "--wait-matching",
        type=float,
        metavar="S",
        help="first wait up to S seconds for a subscriber on --wait-key",
    )
    rep.add_argument(
        "--wait-key",
        metavar="KEYEXPR",
        help="key expression to wait on (default fsw/**)",
    )
    rep.add_argument(
        "--include", action="append", default=[], metavar="KEYEXPR"
    )
    rep.add_argument(
        "--exclude", action="append", default=[], metavar="KEYEXPR"
    )
    add_zenoh_arguments(rep)

    recov = add(
        "recover",
        _cmd_recover,
        "rewrite a truncated MCAP file into a readable one",
    )
    recov.add_argument("file")
    recov.add_argument("--out", required=True, metavar="FILE.mcap")

    inf = add("info", _cmd_info, "summarise an MCAP file")
    inf.add_argument("file")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``fsw-scheduler``; returns the exit code."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=args.log_level.upper(),
        format="%(asctime)s %(levelname)-7s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    try:
        return args.func(args)
    except InputError as error:
        print(f"fsw-scheduler: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except TimeoutError as error:  # an OSError, but not bad input
        print(f"fsw-scheduler: error: {error}", file=sys.stderr)
        return EXIT_NO_PLAN
    except (OSError, McapError) as error:
        # Unreadable or non-MCAP recordings are bad input, not crashes.
        where = (
            getattr(error, "filename", None)
            or " ".join(
                map(
                    str,
                    [
                        getattr(args, "file", None) or "",
                        *getattr(args, "files", []),
                    ],
                )
            ).strip()
        )
        print(f"fsw-scheduler: {where}: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except SchedulerError as error:
        print(f"fsw-scheduler: error: {error}", file=sys.stderr)
        return EXIT_NO_PLAN
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
