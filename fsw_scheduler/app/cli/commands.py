"""The handlers of ``fsw-scheduler``'s commands on files and recordings.

Each subcommand is one ``cmd_*`` function taking the parsed arguments and
returning the exit code (``run`` is in :mod:`fsw_scheduler.app.cli.run`, the
node's composition root). Exit codes: 0 success, 1 infeasible / unknown /
violations, 2 bad input (the message on stderr names the field) or a
missing optional dependency.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import msgspec

from ...errors import ConfigError, FieldIssue, InputError, SchedulerError
from ...model.codec import decode_strict
from ...model.plan import Plan
from ...model.problem import Problem, decode_problem
from .stopping import stop_on_signals

if TYPE_CHECKING:
    import zenoh


log = logging.getLogger("fsw_scheduler")


EXIT_OK, EXIT_NO_PLAN, EXIT_BAD_INPUT = 0, 1, 2


def number_type(
    kind: type[float] | type[int],
    *,
    minimum: float,
    strict: bool,
    maximum: float | None = None,
) -> Callable[[str], float]:
    """An argparse type: a number above (or at) ``minimum``, and at most
    ``maximum`` when given, else exit 2."""

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
        if maximum is not None and value > maximum:
            raise argparse.ArgumentTypeError(f"{text} must be <= {maximum:g}")
        return value

    parse.__name__ = kind.__name__
    return parse


positive_float = number_type(float, minimum=0, strict=True)


non_negative_float = number_type(float, minimum=0, strict=False)


positive_int = number_type(int, minimum=0, strict=True)


def _need_matplotlib(what: str) -> None:
    """Stop before any work when a picture is asked for and cannot be made.

    Raises
    ------
    MissingDependency
        matplotlib is not installed; the message gives the install command.
    """
    from ...view.style import PLOT_INSTALL_HINT, have_matplotlib

    if not have_matplotlib():
        raise MissingDependency(
            f"{what} needs matplotlib, which is not installed: "
            f"{PLOT_INSTALL_HINT} (or leave the option out)"
        )


class MissingDependency(SchedulerError):
    """An optional dependency a requested feature needs is not installed."""


def read_bytes(path: str) -> bytes:
    """The bytes of a file (``-``: stdin); InputError if unreadable."""
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
    return decode_problem(read_bytes(path))


def load_plan(path: str) -> Plan:
    """Read a plan file (``-`` for stdin)."""
    return decode_strict(read_bytes(path), Plan, "plan")


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


def cmd_solve(args: argparse.Namespace) -> int:
    """``fsw-scheduler solve``: solve a problem file, give the plan."""
    from ...solving.solve import solve

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
        from ...view.gantt import gantt

        for page in gantt(problem, plan, Path(args.gantt)):
            log.info("wrote %s", page)
    return EXIT_OK if plan.status.has_plan else EXIT_NO_PLAN


def cmd_check(args: argparse.Namespace) -> int:
    """``fsw-scheduler check``: check a plan against its problem."""
    from ...analysis.check import check_plan, format_report

    problem = load_problem(args.problem)
    plan = load_plan(args.plan)
    report = check_plan(problem, plan)
    print(format_report(report))
    return EXIT_OK if report.ok else EXIT_NO_PLAN


def cmd_replan(args: argparse.Namespace) -> int:
    """``fsw-scheduler replan``: apply a goal or an event, solve again."""
    from ...api import ReplanSettings, replan_typed
    from ...model.change import decode_change
    from ...replan.diff import format_diff

    if args.gantt:
        _need_matplotlib("--gantt")
    problem = load_problem(args.problem)
    plan = load_plan(args.plan)
    change = decode_change(read_bytes(args.change))
    new_problem, new_plan, diff = replan_typed(
        problem,
        plan,
        change,
        args.now,
        solver=args.solver,
        time_limit=args.time_limit,
        settings=ReplanSettings(
            args.commit_window, args.stability, args.move_cost
        ),
    )
    if args.problem_out:
        _write_json(new_problem, args.problem_out)
    _write_json(new_plan, args.out)
    log.info("%s", _summary(new_plan))
    print(format_diff(diff, new_plan), file=sys.stderr)
    if args.gantt and new_plan.status.has_plan:
        from ...model.plan import Moved, SolveStatus
        from ...view.gantt import gantt

        removed = {
            r.task: r.rule
            for r in diff.removed
            if r.rule not in ("finished", "unscheduled")
        }
        # Kept where the window holds them (unless the pins were broken:
        # a degraded plan).
        window = range(args.now, args.now + args.commit_window)
        starts = plan.starts()
        pinned = (
            ()
            if new_plan.status is SolveStatus.DEGRADED
            else [t for t in diff.kept if starts[t] in window]
        )
        for page in gantt(
            new_problem,
            new_plan,
            Path(args.gantt),
            now=args.now,
            removed=removed or None,
            previous=plan.activities,
            moved=[
                Moved(m.task, m.old_start, m.new_start, m.why)
                for m in diff.moved
            ],
            pinned=pinned,
        ):
            log.info("wrote %s", page)
    return EXIT_OK if new_plan.status.has_plan else EXIT_NO_PLAN


def cmd_demo(args: argparse.Namespace) -> int:
    """``fsw-scheduler demo``: run a scenario of the paper."""
    from ..demo import SCENARIOS, run_demo

    if args.scenario == "failover":
        from ..failover_demo import run_failover_demo

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
    from ...view.style import PLOT_INSTALL_HINT, have_matplotlib

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


def _checked_spacecraft(spacecraft: str) -> str:
    check_spacecraft(spacecraft)
    return spacecraft


def check_spacecraft(spacecraft: str | None) -> None:
    """Refuse a spacecraft id that is not a key-safe id (exit 2)."""
    from ...model.limits import id_issue

    reason = None if spacecraft is None else id_issue(spacecraft)
    if reason is not None:
        raise InputError(
            [FieldIssue("--spacecraft", f"the spacecraft id {reason}")],
            "arguments",
        )


def add_spacecraft_flag(parser: argparse.ArgumentParser) -> None:
    """``--spacecraft``: the key prefix id of the commands on the bus."""
    parser.add_argument(
        "--spacecraft",
        default="sat1",
        help="key prefix id (default: %(default)s)",
    )


def open_bus(settings: zenoh.Config) -> zenoh.Session:
    """``zenoh.open``, with Zenoh's errors (a missing certificate, a port
    in use, no route to a client's router) said in one line."""
    import zenoh

    from ...bus.session import plain_zenoh_error
    from ...errors import BusError

    try:
        return zenoh.open(settings)
    except zenoh.ZError as error:
        raise BusError(
            f"cannot open the Zenoh session: {plain_zenoh_error(str(error))}"
        ) from None


def cmd_config(args: argparse.Namespace) -> int:
    """``fsw-scheduler config``: write a secure bus profile."""
    from ...bus.security import write_profile

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


def cmd_probe(args: argparse.Namespace) -> int:
    """``fsw-scheduler probe``: ask which scheduler inputs answer."""

    from ...bus.probe import probe
    from ...bus.session import zenoh_config
    from ...wire.topics import Topics

    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    with open_bus(zenoh_config(args)) as session:
        results = probe(session, Topics(args.spacecraft), kinds, args.timeout)
    for result in results:
        print(f"{result.kind:<7} {result.key}: {result.detail}")
    return EXIT_NO_PLAN if any(r.reached for r in results) else EXIT_OK


def cmd_record(args: argparse.Namespace) -> int:
    """``fsw-scheduler record``: record the bus into an MCAP file."""
    import threading

    from ...bus.record import record
    from ...bus.session import zenoh_config
    from ...journal.annotate import schema_lookup
    from ...journal.writer import Recorder
    from ...wire.topics import Topics

    check_spacecraft(args.spacecraft)
    key = args.key or Topics(args.spacecraft).everything
    stop = threading.Event()
    exclude = [_key_expression(k, "--exclude") for k in args.exclude]
    stop_on_signals(stop)
    # The bus first: an endpoint that cannot be reached leaves no file.
    session = open_bus(zenoh_config(args))
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
    with session, recorder:
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

    from ...journal.annotate import versions

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


def cmd_replay(args: argparse.Namespace) -> int:
    """``fsw-scheduler replay``: replay recordings, or verify them."""
    if args.verify:
        from ...journal.replay import verify

        report = verify(args.files, progress=lambda line: log.info("%s", line))
        print(report.summary())
        return EXIT_OK if report.identical else EXIT_NO_PLAN

    from ...bus.record import replay
    from ...bus.session import zenoh_config
    from ...wire.topics import Topics

    with open_bus(zenoh_config(args)) as session:
        if not args.into_live:
            from ...bus.record import live_schedulers, recorded_spacecraft

            roots = recorded_spacecraft(args.files, dict(args.remap))
            alive = live_schedulers(session, roots)
            if alive:
                for root, tokens in alive.items():
                    print(
                        f"fsw-scheduler: error: a scheduler of {root} is "
                        f"alive on this bus ({tokens[0]}): replaying would "
                        "drive it (its clock, goals and reports); use "
                        "--remap to another spacecraft, or --into-live to "
                        "do it anyway",
                        file=sys.stderr,
                    )
                return EXIT_BAD_INPUT
        if args.wait_matching:
            from ...bus.session import wait_matching

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


def cmd_state(args: argparse.Namespace) -> int:
    """``fsw-scheduler state``: check the journal of a state folder."""
    from ...journal.integrity import check_folder
    from ...journal.state import journal_files

    folder = Path(args.folder)
    if not folder.is_dir():
        print(f"fsw-scheduler: {folder}: no such folder", file=sys.stderr)
        return EXIT_BAD_INPUT
    checks = check_folder(journal_files(folder))
    for check in checks:
        print(check.describe())
    if not checks:
        print(f"{folder}: no journal files (a new state folder)")
    return EXIT_OK if all(c.ok for c in checks) else EXIT_BAD_INPUT


def cmd_recover(args: argparse.Namespace) -> int:
    """``fsw-scheduler recover``: finish an unfinished MCAP file."""
    from ...journal.recover import recover

    kept = recover(args.file, args.out)
    print(f"recovered {sum(kept.values())} messages into {args.out}")
    for topic, count in sorted(kept.items()):
        print(f"  {count:>7}  {topic}")
    return EXIT_OK


def cmd_info(args: argparse.Namespace) -> int:
    """``fsw-scheduler info``: describe a recording (text or JSON)."""
    from ...journal.info import format_info, info, info_dict

    description = info(args.file)
    if args.json:
        _write_json(info_dict(description), None)
    else:
        print(format_info(description))
    return EXIT_OK


def remap_rule(text: str) -> tuple[str, str]:
    """An argparse type: ``OLD=NEW`` key prefixes."""
    from ...bus.record import parse_remap

    try:
        ((old, new),) = parse_remap([text]).items()
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return old, new


def cmd_plot(args: argparse.Namespace) -> int:
    """``fsw-scheduler plot``: draw the pictures of a recorded session."""
    _need_matplotlib("plot")
    from ...view.session import plot_session

    try:
        drawn = plot_session(args.file, args.out)
    except ValueError as error:
        raise InputError([FieldIssue("", str(error))], "journal") from None
    for path in drawn:
        print(path)
    if args.attach_to:
        from ...view.session import attach_pictures

        if Path(args.attach_to).resolve() == Path(args.file).resolve():
            raise InputError(
                [FieldIssue("--attach-to", "must differ from the journal")],
                "arguments",
            )
        print(attach_pictures(args.file, drawn, args.attach_to))
    return EXIT_OK


def cmd_schemas(args: argparse.Namespace) -> int:
    """``fsw-scheduler schemas``: write the formats' JSON Schemas."""
    from ...runtime.schemas import schema_files

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in sorted(schema_files().items()):
        (out / name).write_text(text)
        print(out / name)
    return EXIT_OK


def _shipped(*parts: str) -> Any:
    """A file or folder of ``fsw_scheduler/data`` in the installed
    package (a wheel holds them as package data)."""
    from importlib import resources

    node = resources.files("fsw_scheduler").joinpath("data")
    for part in parts:
        node = node.joinpath(part)
    return node


def cmd_layout(args: argparse.Namespace) -> int:
    """``fsw-scheduler layout``: write the shipped Foxglove layout."""
    text = _shipped("foxglove-layout.json").read_text()
    if args.out is None:
        sys.stdout.write(text)
        return EXIT_OK
    Path(args.out).write_text(text)
    print(args.out)
    return EXIT_OK


def cmd_examples(args: argparse.Namespace) -> int:
    """``fsw-scheduler examples``: write the shipped example files."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for item in sorted(
        _shipped("examples").iterdir(), key=lambda i: str(i.name)
    ):
        if item.is_file():
            (out / item.name).write_text(item.read_text())
            print(out / item.name)
    return EXIT_OK


Command = Callable[[argparse.Namespace], int]
