"""Flags of the commands on the bus: run, config, probe, record, replay.

Zenoh's own flag names: ``--mode``, ``--connect``, ``--listen``,
``--config``, ``--cfg``.
"""

from __future__ import annotations

import textwrap
from typing import TYPE_CHECKING

from ...bus.probe import KINDS
from ...bus.security import (
    DEFAULT_PORT,
    PROFILES,
    ROLES,
    ROUTER,
    TOPOLOGIES,
)
from ...bus.session import add_zenoh_arguments
from ...runtime.config import MAX_MOVE_COST

if TYPE_CHECKING:
    from .files_flags import Add

    pass
from .commands import (
    add_spacecraft_flag,
    cmd_config,
    cmd_probe,
    cmd_record,
    cmd_replay,
    non_negative_float,
    number_type,
    positive_float,
    positive_int,
    remap_rule,
)
from .run import cmd_run


def add_run_command(add: Add) -> None:
    """The ``run`` command and its flags."""
    run = add(
        "run",
        cmd_run,
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
        it, --require-secure refuses to start (exit 2), and so it does on
        a loopback bus without them unless --trust-loopback.
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
        "--state-max-bytes",
        type=positive_int,
        default=1024 * 1024 * 1024,
        metavar="BYTES",
        help="with --state: the folder's budget; past it, the oldest journal "
        "files go once a newer one opens with the state (default "
        "%(default)s)",
    )
    run.add_argument(
        "--new-problem",
        action="store_true",
        help="with --state: when --problem differs from the one the folder "
        "started from, set the folder's state aside (in DIR/replaced/) and "
        "start from the new problem (without it, such a start is refused)",
    )
    run.add_argument(
        "--keep-runs",
        type=number_type(int, minimum=2, strict=False),
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
        type=number_type(int, minimum=0, strict=False),
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
        help="refuse to start (exit 2) unless the bus has mutual TLS on "
        "every endpoint and access control, on loopback too (every "
        "process of the computer reaches a loopback bus)",
    )
    # Not in the group: it qualifies --require-secure, so it goes with it.
    run.add_argument(
        "--trust-loopback",
        action="store_true",
        help="with --require-secure: accept a loopback-only bus without "
        "TLS or access control (a single trusted computer, a bench)",
    )
    limits = run.add_argument_group(
        "limits",
        "What a sender gets beyond each limit is in docs/robustness.md; "
        "the same settings exist in the TOML file.",
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
    replans = run.add_argument_group(
        "predictable replans",
        "What a replan may move (docs/rescheduling.md, 'Predictable "
        "replans'); the same settings exist in the TOML file.",
    )
    replans.add_argument(
        "--commit-window",
        type=number_type(int, minimum=0, strict=False),
        metavar="UNITS",
        help="a replan keeps every planned activity starting within this "
        "many units of it where it was (default 0: none)",
    )
    replans.add_argument(
        "--stability",
        choices=("off", "moves", "lexicographic"),
        help="off: move anything for the least cost; moves: each moved "
        "activity costs --move-cost; lexicographic: fewest moves before "
        "least delay (default off)",
    )
    replans.add_argument(
        "--move-cost",
        type=number_type(int, minimum=1, strict=False, maximum=MAX_MOVE_COST),
        metavar="N",
        help=f"price of one moved activity under --stability moves (1 to "
        f"{MAX_MOVE_COST}, default 5)",
    )
    replans.add_argument(
        "--early-completion-gain",
        type=number_type(int, minimum=0, strict=False),
        metavar="UNITS",
        help="replan when an activity completes at least this many units "
        "before the end of its dispatch (default 0: never)",
    )
    add_zenoh_arguments(run)


def add_config_command(add: Add) -> None:
    """The ``config`` command and its flags."""
    conf = add(
        "config",
        cmd_config,
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
    add_spacecraft_flag(conf)
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


def add_probe_command(add: Add) -> None:
    """The ``probe`` command and its flags."""
    prb = add(
        "probe",
        cmd_probe,
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
    add_spacecraft_flag(prb)
    prb.add_argument(
        "--timeout",
        type=float,
        default=10.0,
        metavar="S",
        help="seconds to wait for the scheduler (default: %(default)s)",
    )
    add_zenoh_arguments(prb)


def add_record_command(add: Add) -> None:
    """The ``record`` command and its flags."""
    rec = add(
        "record",
        cmd_record,
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


def add_replay_command(add: Add) -> None:
    """The ``replay`` command and its flags."""
    rep = add(
        "replay",
        cmd_replay,
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
        type=remap_rule,
        metavar="OLD=NEW",
        help="publish keys under OLD (a key prefix, chunk by chunk) under "
        "NEW instead, e.g. fsw/sat1=fsw/sat2 (repeatable; the first "
        "matching rule applies; filters see the recorded keys)",
    )
    rep.add_argument(
        "--into-live",
        action="store_true",
        help="publish even where a scheduler of a recorded spacecraft is "
        "alive on the bus (by default replay refuses: it would drive that "
        "scheduler)",
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
