"""The node's composition root: ``fsw-scheduler run``.

Loads the settings, assesses the security profile, opens the state folder
and its journal, sets the signals, and runs one node alone or a redundant
member that takes over when the commander goes; on a takeover or resume
the engine is rebuilt from the journal first.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ...errors import FieldIssue, InputError
from ...model.problem import Problem, decode_problem

if TYPE_CHECKING:
    import argparse

    from ...runtime.config import NodeConfig

    pass
from .commands import (
    EXIT_BAD_INPUT,
    EXIT_NO_PLAN,
    EXIT_OK,
    log,
    open_bus,
    read_bytes,
)
from .run_flags import run_settings
from .stopping import stop_on_signals


def cmd_run(args: argparse.Namespace) -> int:
    """``fsw-scheduler run``: the scheduler node, until stopped."""
    import threading
    import time

    from ...bus.node import SchedulerNode
    from ...bus.session import zenoh_config
    from ...journal.annotate import schema_lookup
    from ...journal.writer import Recorder

    config = node_settings(args)
    if config.node_id is None:
        from ...bus.members import default_node_id

        config = config.replace(node_id=default_node_id())
    if args.problem:
        problem = decode_problem(read_bytes(args.problem), allow_empty=True)
    else:
        if config.horizon is None:
            raise InputError(
                [FieldIssue("horizon", "give --problem or --horizon")],
                "arguments",
            )
        problem = Problem(horizon=config.horizon, tasks=())
    from ...bus.security import assess, local_gaps, policy_publishers

    zenoh_settings = zenoh_config(args)
    security = assess(zenoh_settings, acknowledged=args.insecure)
    strict = [*security.warnings]
    if not args.trust_loopback:
        strict += local_gaps(security)
    if strict and args.require_secure:
        for warning in strict:
            print(f"fsw-scheduler: insecure bus: {warning}", file=sys.stderr)
        print(
            "fsw-scheduler: --require-secure: not starting (see 'fsw-"
            "scheduler config --profile secure' and docs/deploying.md, "
            "'Deploying securely')",
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
        from ...journal.state import StateDamaged, damaged_files

        # Before the bus: a node that cannot resume says so and exits 2.
        damaged = damaged_files(Path(args.state))
        if damaged:
            raise StateDamaged(damaged)
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
    stop_on_signals(stop, lambda sig: log.info("signal %d: stopping", sig))
    with open_bus(zenoh_settings) as session:
        redundancy: Any = None

        def make_node(
            state: Any = None,
            event: str = "took_over",
            term_floor: int = 0,
            on_term: Any = None,
        ) -> SchedulerNode:
            """The node that commands: from a state given by the election
            (the newest shared one, or its own after standing down), in a
            term above ``term_floor``."""
            shared = state
            nonlocal journal
            extra: dict[str, Any] = {}
            noted = on_term
            if args.state:
                from ...journal.state import write_term_mark

                def noted(term: int) -> str | None:
                    fault = write_term_mark(Path(args.state), term)
                    if on_term is not None:
                        on_term(term)
                    return fault

                # Opened only to command: a standby keeps only the state
                # it is shared (StandbyStore), not a journal.
                if journal is not None:
                    journal.close()
                journal, opened = _open_state(args, config, problem)
                extra.update(opened)
                folder = opened.get("engine")
                term_floor = _with_mark(
                    Path(args.state),
                    term_floor,
                    folder.term if folder is not None else 0,
                    shared.term if shared is not None else 0,
                )
                if (
                    shared is not None
                    and folder is not None
                    and (folder.term, folder.snapshot().inputs)
                    >= (shared.term, shared.inputs)
                ):
                    # The folder holds the newest state (a standby's
                    # saved copy, or this node's own): resume it.
                    shared = None
                    extra["resumed_event"] = event
            if shared is not None:
                from ...engine.core import Engine
                from ...runtime.policy import engine_config

                extra["engine"] = Engine.restore(engine_config(config), shared)
                extra["resumed_event"] = event
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
                term_floor=term_floor,
                on_term=noted,
                vouched=(
                    redundancy.vouched() if redundancy is not None else None
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
            from ...bus.lease import Lease, has_links, zenoh_lease_s
            from ...bus.redundancy import Member, Redundancy, serve

            member = Member(config.rank, time.time_ns(), config.node_id or "")
            redundancy = Redundancy(session, config.spacecraft, member)
            # A standby follows the commander's records with these.
            redundancy.shared.config = config
            if args.state:
                _standby_state(args, config, problem, redundancy)
            redundancy.join()
            node = None
            try:
                lease_s = zenoh_lease_s(zenoh_settings)
                node = serve(
                    redundancy,
                    make_node,
                    stop,
                    config.discovery,
                    lambda: Lease(
                        lease_s,
                        # Isolation counts once other schedulers were
                        # seen: alone, a tool's link leaving is no cut.
                        lambda: (
                            has_links(session) or not redundancy.seen_others
                        ),
                    ),
                    settle_s=lease_s,
                )
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


def _with_mark(folder: Path, floor: int, *known: int) -> int:
    """``floor`` raised to ``folder``'s term mark, which outlives journal
    files moved aside or lost. A mark whose next term would be beyond the
    bound above every term known (receivers would refuse it) is not
    believed: said in the log, and replaced by the highest term known, so
    that the mark goes on protecting the folder."""
    from ...journal.state import read_term_mark, write_term_mark
    from ...wire.terms import term_refused

    mark, verified = read_term_mark(folder), max(floor, *known)
    refused = term_refused(mark + 1, verified)
    if refused is not None:
        log.error("%s: term mark %d ignored: %s", folder, mark, refused)
        write_term_mark(folder, verified, replace=True)
        return floor
    return max(floor, mark)


def _standby_state(
    args: argparse.Namespace, config: Any, problem: Any, redundancy: Any
) -> None:
    """Before the election: read this node's folder (its term and state
    are what it knows, and what it tells peers it holds), and keep the
    state a commander shares in it while standing by."""
    from ...journal.annotate import schema_lookup
    from ...journal.state import (
        FolderIdentity,
        StandbyStore,
        open_state,
        problem_digest,
        run_number,
    )
    from ...runtime.policy import node_info
    from ...wire import messages, topics

    given = (
        problem
        if config.horizon is None
        else problem.replace(horizon=config.horizon)
    )
    folder = Path(args.state)
    start = open_state(
        folder,
        keep_runs=args.keep_runs,
        identity=FolderIdentity(config.spacecraft, problem_digest(given)),
        new_problem=args.new_problem,
    )
    if start.rebuilt is not None:
        redundancy.hold(start.rebuilt.engine.snapshot())
    keys = topics.Topics(config.spacecraft)
    redundancy.shared.store = StandbyStore(
        folder,
        run_number(start.next_journal),
        (
            keys.key(topics.NODE_INFO),
            messages.encode(node_info(config, given)),
        ),
        keys.key(topics.SNAPSHOT),
        schema_lookup(config.spacecraft),
    )


def _open_state(
    args: argparse.Namespace, config: Any, problem: Any
) -> tuple[Any, dict[str, Any]]:
    """Open ``--state DIR``: rebuild from its journal, start a new file.

    Returns the recorder and the resume arguments of the node.
    """
    import time

    from ...journal.annotate import schema_lookup
    from ...journal.state import FolderIdentity, open_state, problem_digest
    from ...journal.writer import Recorder

    given = (
        problem
        if config.horizon is None
        else problem.replace(horizon=config.horizon)
    )
    start = open_state(
        Path(args.state),
        keep_runs=args.keep_runs,
        identity=FolderIdentity(config.spacecraft, problem_digest(given)),
        new_problem=args.new_problem,
    )
    for path in start.set_aside:
        log.warning("set aside %s (not this folder's session)", path)
    for path in start.recovered:
        log.warning("recovered truncated journal %s", path)
    fault = None
    try:
        journal = Recorder(
            start.next_journal,
            schemas=schema_lookup(config.spacecraft),
            durable=True,
        )
    except OSError as error:
        # A full or failing disk: command anyway, loudly, without
        # durability; the node opens the journal when it can.
        fault = f"{type(error).__name__}: {error}"
        log.error("cannot open the journal: %s; starting without it", fault)
        journal = Recorder(
            start.next_journal,
            schemas=schema_lookup(config.spacecraft),
            open_now=False,
            durable=True,
        )
    resume: dict[str, Any] = {
        "journal_fault": fault,
        "durable": True,
        "journal_max_bytes": args.journal_max_size,
        "state_max_bytes": args.state_max_bytes,
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
        from ...engine.core import Engine
        from ...runtime.policy import engine_config

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


def node_settings(args: argparse.Namespace) -> NodeConfig:
    """The node's settings: the ``--settings`` file, then the flags of
    ``run`` given on the command line over it (:data:`.run_flags.RUN_FLAGS`).

    Raises
    ------
    ConfigError
        The settings file is unreadable or wrong (exit 2).
    InputError
        A flag's value breaks a rule of the settings (exit 2).
    """
    from ...bus.session import settings_file
    from ...runtime.config import load_config

    try:
        return load_config(settings_file(args)).replace(**run_settings(args))
    except ValueError as error:  # a bad value given as a flag
        issues = getattr(error, "issues", None) or [FieldIssue("", str(error))]
        raise InputError(issues, "arguments") from None
