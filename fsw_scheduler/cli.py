"""The ``fsw-scheduler`` command line.

Each subcommand is one ``_cmd_*`` function taking the parsed arguments and
returning the exit code; ``main`` only parses and dispatches. Exit codes:
0 success, 1 infeasible / unknown / violations, 2 bad input (the message on
stderr names the field) or a missing optional dependency.
"""

from __future__ import annotations

import argparse
import logging
import sys
import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec
from mcap.exceptions import McapError

from .errors import ConfigError, FieldIssue, InputError, SchedulerError
from .model.plan import Plan
from .model.problem import Problem, decode_problem, decode_strict

if TYPE_CHECKING:
    import zenoh

log = logging.getLogger("fsw_scheduler")

EXIT_OK, EXIT_NO_PLAN, EXIT_BAD_INPUT = 0, 1, 2
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
  fsw-scheduler demo --scenario failover  two redundant nodes, killed
"""

EPILOG = """\
exit codes: 0 ok, 1 no plan (infeasible / unknown) or violations,
2 bad input (stderr names the field and the reason).
Formats: the README describes the problem, plan, goal and bus message
formats; `fsw-scheduler schemas --out DIR` writes their JSON Schemas.
"""


def _number(
    kind: type[float] | type[int], *, minimum: float, strict: bool
) -> Callable[[str], float]:
    """An argparse type: a number above (or at) ``minimum``, else exit 2."""

    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{text!r} is not a{'n integer' if kind is int else ' number'}"
            ) from None
        if value != value or value in (float("inf"), float("-inf")):
            raise argparse.ArgumentTypeError(f"{text!r} is not finite")
        if value < minimum or (strict and value == minimum):
            raise argparse.ArgumentTypeError(
                f"{text} must be {'>' if strict else '>='} {minimum:g}"
            )
        return value

    parse.__name__ = kind.__name__
    return parse


positive_float = _number(float, minimum=0, strict=True)
non_negative_float = _number(float, minimum=0, strict=False)
positive_int = _number(int, minimum=0, strict=True)


def _need_matplotlib(what: str) -> None:
    """Stop before any work when a picture is asked for and cannot be made.

    Raises
    ------
    MissingDependency
        matplotlib is not installed; the message gives the install command.
    """
    from .view.gantt import PLOT_INSTALL_HINT, have_matplotlib

    if not have_matplotlib():
        raise MissingDependency(
            f"{what} needs matplotlib, which is not installed: "
            f"{PLOT_INSTALL_HINT} (or leave the option out)"
        )


class MissingDependency(SchedulerError):
    """An optional dependency a requested feature needs is not installed."""


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


def _cmd_solve(args: argparse.Namespace) -> int:
    from .solving.solve import solve

    if args.gantt:
        _need_matplotlib("--gantt")
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
        from .view.gantt import gantt

        gantt(problem, plan, Path(args.gantt))
        log.info("wrote %s", args.gantt)
    return EXIT_OK if plan.status.has_plan else EXIT_NO_PLAN


# -- check ------------------------------------------------------------------


def _cmd_check(args: argparse.Namespace) -> int:
    from .analysis.check import check_plan, format_report

    problem = load_problem(args.problem)
    plan = load_plan(args.plan)
    report = check_plan(problem, plan)
    print(format_report(report))
    return EXIT_OK if report.ok else EXIT_NO_PLAN


# -- replan -----------------------------------------------------------------


def _cmd_replan(args: argparse.Namespace) -> int:
    from .api import replan_typed
    from .model.change import decode_change
    from .replan.diff import format_diff

    if args.gantt:
        _need_matplotlib("--gantt")
    problem = load_problem(args.problem)
    plan = load_plan(args.plan)
    change = decode_change(_read_bytes(args.change))
    new_problem, new_plan, diff = replan_typed(
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
        from .view.gantt import gantt

        removed = {
            r.task: r.rule
            for r in diff.removed
            if r.rule not in ("finished", "unscheduled")
        }
        gantt(
            new_problem,
            new_plan,
            Path(args.gantt),
            now=args.now,
            removed=removed or None,
            previous=plan.activities,
        )
        log.info("wrote %s", args.gantt)
    return EXIT_OK if new_plan.status.has_plan else EXIT_NO_PLAN


# -- demo --------------------------------------------------------------------


def _cmd_demo(args: argparse.Namespace) -> int:
    from .app.demo import SCENARIOS, run_demo

    if args.scenario == "failover":
        from .app.failover_demo import run_failover_demo

        log.info("demo (failover scenario): state folders in %s", args.out)
        outcome = run_failover_demo(
            Path(args.out), quiet=args.quiet, time_unit=args.time_unit
        )
        if outcome.takeovers:
            print(
                "takeover after SIGKILL: "
                + ", ".join(f"{t * 1000:.0f} ms" for t in outcome.takeovers)
            )
        return EXIT_OK if outcome.verified else EXIT_NO_PLAN
    from .view.gantt import PLOT_INSTALL_HINT, have_matplotlib

    out = Path(args.out)
    log.info("demo (%s scenario): output in %s", args.scenario, out)
    pictures = have_matplotlib()
    if not pictures:
        log.warning(
            "matplotlib is not installed: the demo runs without pictures "
            "(text timelines only); for pictures: %s",
            PLOT_INSTALL_HINT,
        )
    result = run_demo(
        out,
        scenario=SCENARIOS[args.scenario](),
        spacecraft=_checked_spacecraft(args.spacecraft),
        verify=not args.no_verify,
        quiet=args.quiet,
        time_unit=args.time_unit,
        pictures=pictures,
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
    from .model.problem import id_issue

    reason = None if spacecraft is None else id_issue(spacecraft)
    if reason is not None:
        raise InputError(
            [FieldIssue("--spacecraft", f"the spacecraft id {reason}")],
            "arguments",
        )


def _open_bus(settings: zenoh.Config) -> zenoh.Session:
    """``zenoh.open``, with Zenoh's errors (a missing certificate, a port
    in use, no route to a client's router) said in one line."""
    import zenoh

    from .errors import BusError

    try:
        return zenoh.open(settings)
    except zenoh.ZError as error:
        # Zenoh appends the Rust source location: keep the first sentence.
        text = str(error).split(" at /")[0]
        raise BusError(f"cannot open the Zenoh session: {text}") from None


def _cmd_run(args: argparse.Namespace) -> int:
    import signal
    import threading
    import time

    from .bus.node import SchedulerNode
    from .bus.session import settings_file, zenoh_config
    from .journal.annotate import schema_lookup
    from .journal.writer import Recorder
    from .model.problem import Problem
    from .runtime.config import load_config

    try:
        config = load_config(settings_file(args)).replace(
            spacecraft=args.spacecraft,
            clock=args.clock,
            time_unit=args.time_unit,
            solver=args.solver,
            time_limit=args.time_limit,
            horizon=args.horizon,
            node_id=args.node_id,
            rank=args.rank,
            discovery=args.discovery,
            response_deadline=args.response_deadline,
            tasks_per_goal=args.tasks_per_goal,
            live_tasks=args.live_tasks,
            goals_waiting=args.goals_waiting,
            max_clock_step=args.max_clock_step,
            clock_stall=args.clock_stall,
        )
        if args.no_standby:
            config = config.replace(standby=False)
    except ValueError as error:  # a bad value given as a flag
        raise InputError([FieldIssue("", str(error))], "arguments") from None
    if config.node_id is None:
        from .bus.redundancy import default_node_id

        config = config.replace(node_id=default_node_id())
    if args.problem:
        problem = decode_problem(_read_bytes(args.problem), allow_empty=True)
    else:
        if config.horizon is None:
            raise InputError(
                [FieldIssue("horizon", "give --problem or --horizon")],
                "arguments",
            )
        problem = Problem(horizon=config.horizon, tasks=())
    from .bus.security import assess, policy_publishers

    zenoh_settings = zenoh_config(args)
    security = assess(zenoh_settings, acknowledged=args.insecure)
    if security.warnings and args.require_secure:
        for warning in security.warnings:
            print(f"fsw-scheduler: insecure bus: {warning}", file=sys.stderr)
        print(
            "fsw-scheduler: --require-secure: not starting (see 'fsw-"
            "scheduler config --profile secure' and the README, 'Deploying "
            "securely')",
            file=sys.stderr,
        )
        return EXIT_BAD_INPUT
    for warning in security.warnings:
        if args.insecure:
            log.info("running open (--insecure): %s", warning)
        else:
            log.warning("INSECURE: %s", warning)
    if security.warnings and not args.insecure:
        log.warning(
            "INSECURE: anyone who reaches this bus can command the "
            "scheduler; use a secure profile ('fsw-scheduler config "
            "--profile secure'), or pass --insecure to acknowledge"
        )
    journal = None
    if args.state:
        if args.record:
            raise InputError(
                [
                    FieldIssue(
                        "--record",
                        "--state keeps its own journal; give one of them",
                    )
                ],
                "arguments",
            )
    elif args.record:
        journal = Recorder(
            args.record, schemas=schema_lookup(config.spacecraft)
        )
    stop = threading.Event()

    def on_signal(signum: int, _frame: object) -> None:
        log.info("signal %d: stopping", signum)
        stop.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    with _open_bus(zenoh_settings) as session:
        redundancy: Any = None

        def make_node(shared: Any = None) -> SchedulerNode:
            """The node that commands; from the active's state on takeover."""
            nonlocal journal
            extra: dict[str, Any] = {}
            if args.state:
                # Opened only to command: a standby writes no journal.
                if journal is not None:
                    journal.close()
                journal, opened = _open_state(args, config)
                extra.update(opened)
            if shared is not None:
                from .engine.core import Engine
                from .runtime.policy import engine_config

                extra["engine"] = Engine.restore(engine_config(config), shared)
                extra["resumed_event"] = "took_over"
                extra.pop("clock_start", None)
                if config.clock == "wall" and shared.now is not None:
                    extra["clock_start"] = shared.now
            return SchedulerNode(
                session,
                problem,
                config,
                journal=journal,
                security=security,
                publishers=policy_publishers(zenoh_settings),
                share_state=(
                    redundancy.has_peers if redundancy is not None else False
                ),
                **extra,
            )

        node: SchedulerNode | None
        if not config.standby:
            node = make_node()
            node.start()
            try:
                # The node stops itself when its loop cannot go on.
                while not stop.is_set() and not node.wait_stopped(0.2):
                    pass
            finally:
                node.close()
        else:
            from .bus.redundancy import Member, Redundancy, serve

            member = Member(config.rank, time.time_ns(), config.node_id or "")
            redundancy = Redundancy(session, config.spacecraft, member)
            redundancy.join()
            node = None
            try:
                node = serve(redundancy, make_node, stop, config.discovery)
            finally:
                if node is not None:
                    node.close()
                redundancy.close()
        if node is None:
            return EXIT_OK
    if node.failed is not None:
        print(f"fsw-scheduler: error: {node.failed}", file=sys.stderr)
        return EXIT_NO_PLAN
    return EXIT_OK


# -- config ------------------------------------------------------------------


def _cmd_config(args: argparse.Namespace) -> int:
    from .bus.security import write_profile
    from .errors import ConfigError

    names: dict[str, list[str]] = {}
    for entry in args.cn:
        role, sep, value = entry.partition("=")
        if not sep:
            print(
                f"fsw-scheduler: --cn {entry!r}: expected ROLE=NAME[,NAME]",
                file=sys.stderr,
            )
            return EXIT_BAD_INPUT
        names.setdefault(role.strip(), []).extend(
            v.strip() for v in value.split(",")
        )
    try:
        written = write_profile(
            args.out,
            profile=args.profile,
            spacecraft=args.spacecraft,
            certs=args.certs,
            endpoint=args.endpoint,
            listen=args.listen,
            names=names,
            topology=args.topology,
        )
    except ConfigError as error:
        print(f"fsw-scheduler: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    for path in written:
        print(path)
    return EXIT_OK


def _open_state(
    args: argparse.Namespace, config: Any
) -> tuple[Any, dict[str, Any]]:
    """Open ``--state DIR``: rebuild from its journal, start a new file.

    Returns the recorder and the resume arguments of the node.
    """
    import time

    from .journal.annotate import schema_lookup
    from .journal.state import open_state
    from .journal.writer import Recorder

    start = open_state(Path(args.state), keep_runs=args.keep_runs)
    for path in start.recovered:
        log.warning("recovered truncated journal %s", path)
    journal = Recorder(
        start.next_journal, schemas=schema_lookup(config.spacecraft)
    )
    resume: dict[str, Any] = {
        "durable": True,
        "journal_max_bytes": args.journal_max_size,
    }
    rebuilt = start.rebuilt
    if rebuilt is not None:
        engine = rebuilt.engine
        if rebuilt.config.spacecraft != config.spacecraft:
            raise InputError(
                [
                    FieldIssue(
                        "--state",
                        f"holds the journal of spacecraft "
                        f"{rebuilt.config.spacecraft!r}, not "
                        f"{config.spacecraft!r}",
                    )
                ],
                "arguments",
            )
        # The rebuilt state, under this start's settings (node id, limits).
        from .engine.core import Engine
        from .runtime.policy import engine_config

        resume["engine"] = Engine.restore(
            engine_config(config), engine.snapshot()
        )
        if config.clock == "wall" and rebuilt.last_tick is not None:
            # Time went on while the node was down.
            down_s = max(time.time_ns() - rebuilt.last_log_time_ns, 0) / 1e9
            resume["clock_start"] = rebuilt.last_tick + int(
                down_s // config.time_unit
            )
        log.info(
            "resuming from %s: plan %s at t=%s (%d journal messages read)",
            args.state,
            engine.plan_id,
            engine.now,
            rebuilt.messages,
        )
    else:
        log.info("new state folder %s", args.state)
    return journal, resume


def _cmd_probe(args: argparse.Namespace) -> int:

    from .bus.probe import probe
    from .bus.session import zenoh_config
    from .wire.topics import Topics

    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    with _open_bus(zenoh_config(args)) as session:
        results = probe(session, Topics(args.spacecraft), kinds, args.timeout)
    for result in results:
        print(f"{result.kind:<7} {result.key}: {result.detail}")
    return EXIT_NO_PLAN if any(r.reached for r in results) else EXIT_OK


# -- record / replay / recover / info ----------------------------------------


def _cmd_record(args: argparse.Namespace) -> int:
    import signal
    import threading

    import zenoh

    from .bus.record import record
    from .bus.session import zenoh_config
    from .journal.annotate import schema_lookup
    from .journal.writer import Recorder
    from .wire.topics import Topics

    _check_spacecraft(args.spacecraft)
    key = args.key or Topics(args.spacecraft).everything
    stop = threading.Event()
    exclude = [_key_expression(k, "--exclude") for k in args.exclude]
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
        only_json=args.json_only,
    )
    with zenoh.open(zenoh_config(args)) as session, recorder:
        recorder.add_metadata(
            "fsw_scheduler.recording",
            recording_metadata(key, exclude, args.spacecraft),
        )
        log.info("recording %s to %s (Ctrl-C to stop)", key, args.out)
        stats = record(session, key, recorder, stop, exclude=exclude)
    log.info(
        "recorded %d messages on %d keys into %s",
        stats.written,
        len(stats.by_key),
        ", ".join(map(str, recorder.paths)),
    )
    if stats.skipped or stats.excluded:
        log.info(
            "left out: %d non-JSON samples, %d on excluded keys",
            stats.skipped,
            stats.excluded,
        )
    return EXIT_OK


def recording_metadata(
    key: str, exclude: Sequence[str], spacecraft: str
) -> dict[str, str]:
    """The ``fsw_scheduler.recording`` metadata of a ``record`` file."""
    import time
    from datetime import datetime, timezone

    from .journal.annotate import versions

    now = datetime.fromtimestamp(time.time(), tz=timezone.utc)
    return {
        "key": key,
        "exclude": " ".join(exclude),
        "spacecraft": spacecraft,
        "start_time": now.isoformat(timespec="milliseconds").replace(
            "+00:00", "Z"
        ),
        **versions(),
    }


def _key_expression(text: str, flag: str) -> str:
    """Refuse a malformed key expression before opening the bus."""
    import zenoh

    try:
        return str(zenoh.KeyExpr(text))
    except zenoh.ZError as error:
        raise InputError(
            [FieldIssue(flag, f"{text!r} is not a key expression: {error}")],
            "arguments",
        ) from None


def _cmd_replay(args: argparse.Namespace) -> int:
    if args.verify:
        from .journal.replay import verify

        report = verify(args.files, progress=lambda line: log.info("%s", line))
        print(report.summary())
        return EXIT_OK if report.identical else EXIT_NO_PLAN
    import zenoh

    from .bus.record import replay
    from .bus.session import zenoh_config
    from .wire.topics import Topics

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
            remap=dict(args.remap),
            clock_key=(
                None
                if args.clock is None
                else args.clock_key or Topics(args.spacecraft).key("clock")
            ),
            clock_unit_s=args.clock or 1.0,
        )
    log.info("published %d messages", count)
    return EXIT_OK


def _cmd_recover(args: argparse.Namespace) -> int:
    from .journal.recover import recover

    kept = recover(args.file, args.out)
    print(f"recovered {sum(kept.values())} messages into {args.out}")
    for topic, count in sorted(kept.items()):
        print(f"  {count:>7}  {topic}")
    return EXIT_OK


def _cmd_info(args: argparse.Namespace) -> int:
    from .journal.info import format_info, info, info_dict

    description = info(args.file)
    if args.json:
        _write_json(info_dict(description), None)
    else:
        print(format_info(description))
    return EXIT_OK


def _remap_rule(text: str) -> tuple[str, str]:
    """An argparse type: ``OLD=NEW`` key prefixes."""
    from .bus.record import parse_remap

    try:
        ((old, new),) = parse_remap([text]).items()
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return old, new


def _cmd_plot(args: argparse.Namespace) -> int:
    _need_matplotlib("plot")
    from .view.session import plot_session

    try:
        drawn = plot_session(args.file, args.out)
    except ValueError as error:
        raise InputError([FieldIssue("", str(error))], "journal") from None
    for path in drawn:
        print(path)
    if args.attach_to:
        from .view.session import attach_pictures

        if Path(args.attach_to).resolve() == Path(args.file).resolve():
            raise InputError(
                [FieldIssue("--attach-to", "must differ from the journal")],
                "arguments",
            )
        print(attach_pictures(args.file, drawn, args.attach_to))
    return EXIT_OK


def _cmd_schemas(args: argparse.Namespace) -> int:
    from .runtime.schemas import schema_files

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in sorted(schema_files().items()):
        (out / name).write_text(text)
        print(out / name)
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
        choices=LOG_LEVELS,
        help="log verbosity on stderr (default: %(default)s)",
    )
    # The same flag after the command name (`solve --log-level debug`);
    # SUPPRESS keeps the value given before the command when absent here.
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--log-level",
        default=argparse.SUPPRESS,
        choices=LOG_LEVELS,
        help="log verbosity on stderr (default: info)",
    )
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

    solve = add(
        "solve",
        _cmd_solve,
        "solve a problem file and print the plan JSON",
        """\
        Solve a problem file (format: README, "Problem, plan and goal
        files"; schema: `fsw-scheduler schemas`) and print the plan JSON
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

        example:
          fsw-scheduler check problem.json plan.json
        """,
    )
    check.add_argument("problem", help="problem JSON file")
    check.add_argument("plan", help="plan JSON file")

    replan = add(
        "replan",
        _cmd_replan,
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
        choices=("paper", "failure", "failover"),
        default="paper",
        help="paper: Table 1 then the Table 2 goal; failure: also a failed "
        "activity and a draining battery; failover: the paper scenario on "
        "two redundant schedulers (separate processes) that are killed "
        "and resume or take over (default: %(default)s)",
    )
    demo.add_argument("--spacecraft", default="sat1", help="key prefix id")
    demo.add_argument(
        "--no-verify", action="store_true", help="skip the replay check"
    )
    demo.add_argument("--quiet", action="store_true", help="no live timeline")
    demo.add_argument(
        "--time-unit",
        type=non_negative_float,
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
          fsw-scheduler run --settings scheduler.toml --record session.mcap
          fsw-scheduler run --settings scheduler.toml -c zenoh.json5 \\
              -m client -e tcp/10.0.0.1:7447 --no-multicast-scouting
          fsw-scheduler run --problem p.json -c deploy/scheduler.json5 \\
              --require-secure --state /var/lib/fsw-scheduler

        A bus reachable beyond loopback without TLS or access control is
        reported at start (and in scheduler/config): --insecure accepts
        it, --require-secure refuses to start (exit 2).
        """,
    )
    run.add_argument(
        "--problem",
        metavar="PROBLEM.json",
        help="resources, horizon length and any initial tasks",
    )
    run.add_argument(
        "--settings",
        metavar="FILE.toml",
        help="the scheduler's settings (strict TOML; an unknown key exits "
        "2); flags given here override them. The old form --config "
        "FILE.toml still works, with a deprecation message",
    )
    run.add_argument("--spacecraft", help="key prefix id (default sat1)")
    run.add_argument(
        "--clock",
        choices=("bus", "wall"),
        help="time from fsw/<sc>/clock, or the node's own clock",
    )
    run.add_argument(
        "--time-unit",
        type=positive_float,
        metavar="S",
        help="seconds per time unit with --clock wall",
    )
    run.add_argument(
        "--horizon",
        type=positive_int,
        metavar="H",
        help="horizon length in time units (default: the problem file's)",
    )
    run.add_argument(
        "--record",
        metavar="FILE.mcap",
        help="journal every input and output (for replay --verify)",
    )
    run.add_argument(
        "--state",
        metavar="DIR",
        help="keep the node's state in DIR: a durable journal that a "
        "restarted node resumes from (plan ids, accepted goals, activity "
        "states, a solve in flight); implies journaling",
    )
    run.add_argument(
        "--journal-max-size",
        type=positive_int,
        default=64 * 1024 * 1024,
        metavar="BYTES",
        help="with --state: start a new journal file, opened by a state "
        "snapshot, past this size (default %(default)s)",
    )
    run.add_argument(
        "--keep-runs",
        type=_number(int, minimum=2, strict=False),
        default=20,
        metavar="N",
        help="with --state: journal files of the last N starts are kept "
        "(default %(default)s; at least 2)",
    )
    run.add_argument(
        "--node-id",
        metavar="ID",
        help="this node's name among redundant schedulers (default "
        "<host>-<pid>)",
    )
    run.add_argument(
        "--rank",
        type=_number(int, minimum=0, strict=False),
        metavar="N",
        help="preference among redundant schedulers: the lowest rank "
        "commands when none does yet (default 0)",
    )
    run.add_argument(
        "--discovery",
        type=non_negative_float,
        metavar="S",
        help="seconds to look for other schedulers before commanding "
        "(default 1)",
    )
    run.add_argument(
        "--no-standby",
        action="store_true",
        help="command whatever else runs: no election, no hot standby",
    )
    run.add_argument("--solver", choices=("cbc", "highs"), help="MILP solver")
    run.add_argument(
        "--time-limit",
        type=positive_float,
        metavar="S",
        help="seconds per solve (> 0; default 10)",
    )
    safety = run.add_mutually_exclusive_group()
    safety.add_argument(
        "--insecure",
        action="store_true",
        help="acknowledge a bus reachable beyond loopback without TLS or "
        "access control (recorded in scheduler/config)",
    )
    safety.add_argument(
        "--require-secure",
        action="store_true",
        help="refuse to start (exit 2) unless the bus is loopback only, or "
        "has mutual TLS on every endpoint and access control",
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

    from .bus.security import DEFAULT_PORT, PROFILES, ROLES, ROUTER, TOPOLOGIES

    conf = add(
        "config",
        _cmd_config,
        "write the Zenoh configurations of a deployment profile",
        textwrap.dedent(
            """\
            Write one Zenoh configuration (JSON5) per role of a deployment
            profile, and make-certs.sh, which makes a CA and a certificate
            per role with openssl. The secure profile has mutual TLS on
            every link and access control (default deny) by certificate
            common name. The scheduler listens; every other role connects
            to it.

            roles (configuration <role>.json5, certificate <role>.pem):
            """
        )
        + "\n".join(
            textwrap.fill(
                r.summary,
                width=76,
                initial_indent=f"  {r.name:<10} ",
                subsequent_indent=" " * 13,
            )
            for r in [*ROLES.values(), ROUTER]
        ),
    )
    conf.epilog = f"""\
example:
  fsw-scheduler config --profile secure --out deploy \\
      --endpoint tls/10.0.0.2:{DEFAULT_PORT}
  sh deploy/make-certs.sh
  fsw-scheduler run --problem p.json --config deploy/scheduler.json5 \\
      --require-secure
  fsw-scheduler record --config deploy/monitor.json5 --out bus.mcap
"""
    conf.add_argument(
        "--profile",
        choices=PROFILES,
        default="secure",
        help="deployment profile (default: %(default)s)",
    )
    conf.add_argument(
        "--out",
        required=True,
        metavar="DIR",
        help="folder for <role>.json5 and make-certs.sh",
    )
    conf.add_argument(
        "--spacecraft",
        default="sat1",
        help="key prefix id (default: %(default)s)",
    )
    conf.add_argument(
        "--certs",
        metavar="DIR",
        help="where the certificates are on the nodes: ca.pem, "
        "<role>.pem, <role>.key (default: DIR/certs)",
    )
    conf.add_argument(
        "--endpoint",
        default=f"tls/localhost:{DEFAULT_PORT}",
        metavar="tls/HOST:PORT",
        help="where the roles reach the scheduler; HOST goes into the "
        "scheduler's certificate (default: %(default)s)",
    )
    conf.add_argument(
        "--listen",
        metavar="ENDPOINT",
        help="where the scheduler listens (default: every interface, "
        "--endpoint's port)",
    )
    conf.add_argument(
        "--topology",
        choices=TOPOLOGIES,
        default="star",
        help="star: the scheduler listens, the roles connect to it; router: "
        "a Zenoh router listens (router.json5) and every role, the "
        "scheduler and its redundant twins included, connects to it "
        "(default: %(default)s)",
    )
    conf.add_argument(
        "--cn",
        action="append",
        default=[],
        metavar="ROLE=NAME[,NAME]",
        help="certificate common names of a role (default: the role's "
        "name), e.g. --cn goals=ground,autonomy (repeatable)",
    )

    from .bus.probe import KINDS

    prb = add(
        "probe",
        _cmd_probe,
        "check which inputs the scheduler accepts from this seat",
        """\
        Publish one harmless input of each kind (a goal the scheduler
        rejects, a report on a task and a level of a resource that do not
        exist) and ask the scheduler's status after each, on the same link,
        whether it saw it. Nothing changes the plan; the clock is never
        probed. Exit 0 if every probe was refused, 1 if any reached the
        scheduler.
        """,
    )
    prb.epilog = """\
example (a read-only monitor must be refused everything; the second run
switches the monitor's own policy off to test the scheduler's):
  fsw-scheduler probe --config deploy/monitor.json5
  fsw-scheduler probe --config deploy/monitor.json5 \\
      --cfg access_control/enabled:false
"""
    prb.add_argument(
        "--kinds",
        default=",".join(KINDS),
        metavar="KIND[,KIND]",
        help="which inputs to try, among %(default)s (default: all)",
    )
    prb.add_argument(
        "--spacecraft",
        default="sat1",
        help="key prefix id (default: %(default)s)",
    )
    prb.add_argument(
        "--timeout",
        type=float,
        default=10.0,
        metavar="S",
        help="seconds to wait for the scheduler (default: %(default)s)",
    )
    add_zenoh_arguments(prb)

    rec = add(
        "record",
        _cmd_record,
        "record bus traffic to MCAP",
        """\
        Subscribe to a key expression (default fsw/<sc>/**) and write each
        sample as an MCAP message: one channel per key, JSON encoding with
        the JSON Schema of the key where there is one. Small chunks and a
        periodic flush keep a killed recorder's file recoverable (see
        `recover`). Stop with Ctrl-C or SIGTERM.

        Each sample keeps its Zenoh encoding: JSON samples go to `json`
        channels, others (CBOR, Protobuf, CDR, raw bytes, text...) to
        channels of their own encoding, and `replay` puts them back with
        it; --json-only skips them instead and counts them.

        examples:
          fsw-scheduler record --out session.mcap -e tcp/127.0.0.1:7447
          fsw-scheduler record --out plans.mcap --key 'fsw/sat1/scheduler/**'
          fsw-scheduler record --out day.mcap --split-duration 3600
          fsw-scheduler record --out s.mcap --exclude 'fsw/sat1/clock' \\
              --exclude 'fsw/sat1/telemetry/**' -m client -e tcp/10.0.0.1:7447
        """,
    )
    rec.add_argument(
        "--out",
        required=True,
        metavar="FILE.mcap",
        help="where to write; with splitting, FILE-001.mcap, FILE-002.mcap...",
    )
    rec.add_argument(
        "--key",
        metavar="KEYEXPR",
        help="key expression to record (default fsw/<spacecraft>/**)",
    )
    rec.add_argument(
        "--spacecraft",
        default="sat1",
        help="spacecraft id of the default key and of the JSON Schemas "
        "attached to channels (default %(default)s)",
    )
    rec.add_argument(
        "--exclude",
        action="append",
        default=[],
        metavar="KEYEXPR",
        help="do not record keys matching KEYEXPR (repeatable)",
    )
    rec.add_argument(
        "--json-only",
        action="store_true",
        help="skip samples whose Zenoh encoding is not JSON (counted and "
        "logged) instead of recording them under their own encoding",
    )
    rec.add_argument(
        "--compression",
        choices=("zstd", "lz4", "none"),
        default="zstd",
        help="chunk compression (default %(default)s)",
    )
    rec.add_argument(
        "--split-size",
        type=positive_int,
        metavar="BYTES",
        help="start a new file when this one reaches BYTES",
    )
    rec.add_argument(
        "--split-duration",
        type=positive_float,
        metavar="S",
        help="start a new file every S seconds of log time",
    )
    rec.add_argument(
        "--flush-interval",
        type=positive_float,
        default=1.0,
        metavar="S",
        help="write buffered messages to disk at least every S seconds: "
        "the most a crash can lose (default %(default)s s)",
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

        Options follow rosbag2 where they fit: -r/--rate, --loop,
        --start-offset, --clock (publish a bus clock from the recording's
        time), --remap OLD=NEW (key prefixes, e.g. replay a sat1 session
        as sat2). Each message is published with the Zenoh encoding it
        was recorded with.

        examples:
          fsw-scheduler replay session.mcap --verify
          fsw-scheduler replay session.mcap -r 10 -e tcp/127.0.0.1:7447
          fsw-scheduler replay session.mcap --burst \\
              --include 'fsw/sat1/telemetry/**' --wait-matching 5
          fsw-scheduler replay session.mcap --remap fsw/sat1=fsw/sat2
          fsw-scheduler replay telemetry.mcap --clock 1 --loop \\
              --start-offset 30 --exclude 'fsw/sat1/scheduler/**'
        """,
    )
    rep.add_argument(
        "files",
        nargs="+",
        metavar="FILE.mcap",
        help="recordings (split files are read in order as one session)",
    )
    rep.add_argument(
        "--verify",
        action="store_true",
        help="replay through a fresh scheduler and compare decisions "
        "(no bus needed)",
    )
    rep.add_argument(
        "--rate",
        "-r",
        type=positive_float,
        default=1.0,
        help="speed factor on the recorded log times (default %(default)s)",
    )
    rep.add_argument(
        "--burst", action="store_true", help="as fast as possible, in order"
    )
    rep.add_argument(
        "--start-offset",
        type=non_negative_float,
        default=0.0,
        metavar="S",
        help="skip the first S seconds of the recording",
    )
    rep.add_argument(
        "--until",
        type=non_negative_float,
        metavar="S",
        help="stop S seconds after the start of the recording",
    )
    rep.add_argument(
        "--loop",
        action="store_true",
        help="start again at the end, until Ctrl-C",
    )
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
        "--include",
        action="append",
        default=[],
        metavar="KEYEXPR",
        help="only publish keys matching KEYEXPR (repeatable)",
    )
    rep.add_argument(
        "--exclude",
        action="append",
        default=[],
        metavar="KEYEXPR",
        help="do not publish keys matching KEYEXPR (repeatable)",
    )
    rep.add_argument(
        "--remap",
        action="append",
        default=[],
        type=_remap_rule,
        metavar="OLD=NEW",
        help="publish keys under OLD (a key prefix, chunk by chunk) under "
        "NEW instead, e.g. fsw/sat1=fsw/sat2 (repeatable; the first "
        "matching rule applies; filters see the recorded keys)",
    )
    rep.add_argument(
        "--clock",
        nargs="?",
        const=1.0,
        type=positive_float,
        metavar="S",
        help='also publish a bus clock ({"now": n}) on --clock-key, unit n '
        "at S*n seconds of recording time from its start (S default 1); "
        "recorded messages on that key are not replayed",
    )
    rep.add_argument(
        "--clock-key",
        metavar="KEY",
        help="the clock key, before --remap (default fsw/<spacecraft>/clock)",
    )
    rep.add_argument(
        "--spacecraft",
        default="sat1",
        help="spacecraft of the default --clock-key (default %(default)s)",
    )
    add_zenoh_arguments(rep)

    recov = add(
        "recover",
        _cmd_recover,
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

    inf = add(
        "info",
        _cmd_info,
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

    plo = add(
        "plot",
        _cmd_plot,
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

    sch = add(
        "schemas",
        _cmd_schemas,
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
    except (ConfigError, MissingDependency) as error:
        print(f"fsw-scheduler: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        # The reader went away (`... | head`): stop quietly, as a shell
        # tool killed by SIGPIPE would.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
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
