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


# -- solve -------------------------------------------------------------------


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


# -- check -------------------------------------------------------------------


def _cmd_check(args: argparse.Namespace) -> int:
    from .check import check_plan, format_report

    problem = load_problem(args.problem)
    plan = load_plan(args.plan)
    report = check_plan(problem, plan)
    print(format_report(report))
    return EXIT_OK if report.ok else EXIT_NO_PLAN


# -- replan ------------------------------------------------------------------


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


# -- parser ------------------------------------------------------------------

Command = Callable[[argparse.Namespace], int]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``fsw-scheduler`` (all subcommands)."""
    parser = argparse.ArgumentParser(
        prog="fsw-scheduler",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
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
    except SchedulerError as error:
        print(f"fsw-scheduler: error: {error}", file=sys.stderr)
        return EXIT_NO_PLAN
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
