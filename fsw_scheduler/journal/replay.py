"""Deterministic replay: re-run a recorded session and compare decisions.

A scheduler journal (``fsw-scheduler run --record`` or ``demo``) holds, in
the order the node processed them, every input (goals, telemetry, clock or
the node's own ticks) and every output (plans, dispatches, status, solve
records), plus the node's settings and initial problem on
``scheduler/config``. :func:`verify` feeds the inputs to a fresh
:class:`~fsw_scheduler.engine.Engine` in that order. A solve is run when
the engine asks for it, and its result is handed back exactly where the
recorded solve record says the original result arrived, so the fresh
engine sees the same interleaving of solves and inputs as the recorded one.
Each output is then compared with the recorded output at the same
position.

What "identical" means: outputs are compared as decoded JSON, in order,
key by key and field by field, except the fields listed in
:data:`EXCLUDED`: solver timings and statistics (wall-clock dependent),
``counters.inputs_dropped`` (a property of the live inbox), the ``source``
of status verdicts (who sent an input, a property of the live bus) and
status replies to queries (never recorded). Everything else must match:
plan ids, activities, unscheduled tasks and reasons, objectives, dispatch
times and contents, lifecycle states, rejection messages. Fields that a newer
version added and the recording does not have are not compared, so old
recordings keep verifying as message types grow. Statuses once carried
the whole lifecycle map; now only heartbeats do and the others carry what
``changed``: against such a recording, the map rebuilt from the replayed
statuses (last full map plus every change since) is compared.


Derived channels (``scheduler/profiles``, ``scheduler/levels``,
``scheduler/log``, see :mod:`fsw_scheduler.journal.annotate`) are checked, not
ignored: when the journal has any of them, the replay derives them from
its own stream with the same :class:`~fsw_scheduler.journal.annotate.Annotator`
and compares them in place like any output (``foxglove.Log``
``timestamp``, a wall-clock time, excepted). Journals recorded before
these channels existed have none and are verified without them.
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import msgspec

from ..engine.core import Engine
from ..engine.events import Publish, SolveDone, StartSolve
from ..engine.snapshot import EngineSnapshot
from ..errors import FieldIssue, InputError
from ..model.plan import Plan, SolveStatus
from ..runtime.config import NodeConfig
from ..runtime.inputs import InputDecoder
from ..runtime.policy import config_from_info, engine_config
from ..wire import messages
from ..wire import topics as keys
from .annotate import DERIVED, Annotator, engine_problem
from .info import read_metadata
from .reader import iter_messages
from .whatifs import answer_again, comparable, what_if_states

if TYPE_CHECKING:
    from .writer import PathLike, RecordedMessage

#: Fields left out of the comparison, per output kind (dotted paths).
EXCLUDED: dict[str, tuple[str, ...]] = {
    "plan": ("stats",),
    "status": (
        "counters.inputs_dropped",
        "counters.telemetry_superseded",
        "counters.clock_superseded",
        "counters.goals_busy",
        "counters.queries_dropped",
        "counters.publish_failures",
        "counters.loop_faults",
        "last_solve.wall_s",
        # The source of an input is a property of the live bus (session
        # ids, certificates), not a decision: the engine never sees it.
        "source",
    ),
    "solve_record": (
        "build_s",
        "solve_s",
        "wall_s",
        "num_variables",
        "num_constraints",
        "result.stats",
    ),
    "dispatch": (),
}
#: Derived channels, compared when the journal has them (see above).
DERIVED_EXCLUDED: dict[str, tuple[str, ...]] = {
    "profiles": (),
    "level_check": (),
    "log": ("timestamp",),
}

SolveFn = Callable[[NodeConfig, StartSolve], Plan]


@dataclass
class Divergence:
    """The first place where the replay differs from the recording."""

    index: int
    key_recorded: str | None
    key_replayed: str | None
    recorded: Any
    replayed: Any
    field: str = ""

    def __str__(self) -> str:
        where = f" (field {self.field})" if self.field else ""
        return (
            f"output #{self.index} differs{where}:\n"
            f"  recorded: {self.key_recorded} "
            f"{_short(self.recorded)}\n"
            f"  replayed: {self.key_replayed} "
            f"{_short(self.replayed)}"
        )


@dataclass
class VerifyReport:
    """Outcome of :func:`verify`."""

    inputs: int = 0
    outputs: int = 0
    solves: int = 0
    plans: int = 0
    dispatches: int = 0
    derived: int = 0
    what_ifs: int = 0
    divergence: Divergence | None = None
    notes: list[str] = field(default_factory=list)
    lifecycle: dict[str, str] = field(default_factory=dict, repr=False)

    @property
    def identical(self) -> bool:
        """True if every output matched."""
        return self.divergence is None

    def summary(self) -> str:
        """One paragraph for humans."""
        head = (
            "IDENTICAL: the replay reproduced every recorded decision"
            if self.identical
            else "DIVERGED"
        )
        lines = [
            head,
            f"  inputs fed {self.inputs}, outputs compared {self.outputs} "
            f"(plans {self.plans}, dispatches {self.dispatches}, "
            f"solves {self.solves}"
            + (f", derived {self.derived}" if self.derived else "")
            + (f", what-ifs {self.what_ifs}" if self.what_ifs else "")
            + ")",
            *[f"  note: {n}" for n in self.notes],
        ]
        if self.divergence is not None:
            lines.append(str(self.divergence))
        return "\n".join(lines)


def _short(value: Any, limit: int = 600) -> str:
    text = msgspec.json.encode(value).decode()
    return text if len(text) <= limit else text[:limit] + "..."


def read_node_info(
    messages_: Sequence[RecordedMessage],
) -> tuple[messages.NodeInfo, str]:
    """The node settings recorded on ``fsw/<sc>/scheduler/config``."""
    for message in messages_:
        if message.topic.endswith("/" + keys.NODE_INFO):
            info = msgspec.json.decode(message.payload, type=messages.NodeInfo)
            return info, message.topic
    raise InputError(
        [
            FieldIssue(
                "",
                "no scheduler/config message: not a scheduler journal "
                "(a 'record' file holds bus traffic only; journal with "
                "'fsw-scheduler run --record FILE' or '--state DIR', or "
                "'demo')",
            )
        ],
        "journal",
    )


def _normalise(kind: str, payload: bytes) -> Any:
    value = msgspec.json.decode(payload)
    for dotted in EXCLUDED.get(kind, DERIVED_EXCLUDED.get(kind, ())):
        node = value
        *parents, leaf = dotted.split(".")
        for part in parents:
            node = node.get(part) if isinstance(node, dict) else None
        if isinstance(node, dict):
            node.pop(leaf, None)
    return value


def _first_difference(a: Any, b: Any, path: str = "") -> str:
    if isinstance(a, dict) and isinstance(b, dict):
        for name in sorted(set(a) | set(b)):
            if a.get(name) != b.get(name):
                return _first_difference(
                    a.get(name), b.get(name), f"{path}.{name}".lstrip(".")
                )
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for idx, (x, y) in enumerate(zip(a, b, strict=True)):
            if x != y:
                return _first_difference(x, y, f"{path}[{idx}]")
    return path


def verify(
    paths: PathLike | Sequence[PathLike],
    *,
    solve_fn: SolveFn | None = None,
    progress: Callable[[str], None] | None = None,
) -> VerifyReport:
    """Replay a scheduler journal through a fresh engine and compare.

    Parameters
    ----------
    paths
        The journal (one MCAP file or the parts of a split one).
    solve_fn
        How to solve (default: as the node does, with the recorded solver,
        seed and limits).
    progress
        Called with a short line at each solve.

    Returns
    -------
    VerifyReport
        ``identical`` is True when every output matched.
    """
    from ..runtime.policy import run_solve

    report = VerifyReport()
    if not any(True for _ in iter_messages(paths)):
        # A part whose writer was killed right after it opened it (before
        # the settings and the snapshot that open every part were flushed)
        # holds no message: no decision was taken in it.
        report.notes.append(
            "the journal holds no message (its writer was stopped before "
            "it wrote anything): nothing to reproduce"
        )
        return report
    start = _Start.of(paths)
    recorded, info, info_topic = start.recorded, start.info, start.info_topic
    config, topics, snapshot = start.config, start.topics, start.snapshot
    engine, decoder = start.engine, start.decoder
    solve = solve_fn or run_solve
    records = _solve_records(recorded, topics)
    produced: deque[tuple[str, bytes]] = deque()
    results: dict[int, Plan] = {}
    now = snapshot.now or 0 if snapshot is not None else 0
    derived_keys = {topics.key(suffix) for suffix in DERIVED}
    ticks_key = topics.key(keys.TICKS)
    annotator = (
        Annotator(topics, lambda: engine_problem(engine))
        if any(m.topic in derived_keys for m in recorded)
        else None
    )
    compared = (
        {**EXCLUDED, **DERIVED_EXCLUDED} if annotator is not None else EXCLUDED
    )

    def annotate(key: str, payload: bytes) -> None:
        if annotator is None:
            return
        for item in annotator.observe(key, payload):
            produced.append((topics.key(item.suffix), item.payload))

    def run(commands: list) -> None:
        for command in commands:
            if isinstance(command, Publish):
                key = topics.key(command.suffix)
                payload = messages.encode(command.message)
                produced.append((key, payload))
                annotate(key, payload)
            elif isinstance(command, StartSolve):
                if progress is not None:
                    progress(
                        f"solve {command.solve_id} ({command.trigger}): "
                        f"{command.problem.num_tasks} tasks"
                    )
                results[command.solve_id] = replay_solve(
                    solve, config, command, records, report
                )

    inputs = list(_outputs_and_inputs(recorded, info_topic))
    if snapshot is not None:
        # A file of a state folder starts from the engine's state. A node
        # that resumed began its new term, said so and asked again for the
        # solve that was in flight; after a rotation, that solve is still
        # running.
        inputs = _term_first(inputs, topics, decoder, engine, now, report, run)
        if info.resumed:
            run(engine.resume_commands(info.resumed))
        pending = engine.pending_solve()
        if pending is not None:
            results[pending.solve_id] = replay_solve(
                solve, config, pending, records, report
            )
    asked = what_if_states(recorded, topics)
    states: dict[int, EngineSnapshot] = {}
    for message in inputs:
        if engine.inputs_seen in asked and engine.inputs_seen not in states:
            # The state a journaled what-if was answered from.
            states[engine.inputs_seen] = engine.snapshot()
        kind = topics.schema_kind(message.topic)
        if kind == "what_if":
            if not _verify_what_if(
                message, states, engine, config, solve, report
            ):
                return report
            continue
        if kind == "solve_record":
            record = msgspec.json.decode(message.payload)
            solve_id = int(record["solve_id"])
            plan = results.pop(solve_id, None)
            if plan is None:
                report.notes.append(
                    f"recorded solve {solve_id} was never requested"
                )
            else:
                run(engine.step(SolveDone(solve_id, plan), now))
                report.solves += 1
        if kind in compared:
            if not _compare(report, produced, message, kind):
                return report
            continue
        if message.topic != ticks_key:  # the node annotates bus samples
            annotate(message.topic, message.payload)
        event = decoder.event(message.topic, message.payload)
        if event is None:
            continue
        report.inputs += 1
        if hasattr(event, "now"):
            now = max(now, event.now)
        run(engine.step(event, now))
    if produced:
        key, payload = produced[0]
        report.divergence = Divergence(
            report.outputs,
            None,
            key,
            None,
            msgspec.json.decode(payload),
            "replay published more than the recording",
        )
    return report


@dataclass
class _Start:
    """A journal read, and a fresh engine where the journal starts."""

    recorded: list[RecordedMessage]
    info: messages.NodeInfo
    info_topic: str
    config: NodeConfig
    topics: keys.Topics
    snapshot: EngineSnapshot | None
    engine: Engine
    decoder: InputDecoder

    @classmethod
    def of(cls, paths: PathLike | Sequence[PathLike]) -> _Start:
        """Read ``paths``; the engine starts from the opening snapshot, or
        from the initial problem of ``scheduler/config``."""
        recorded = list(iter_messages(paths))
        info, info_topic = read_node_info(recorded)
        if info.problem is None:
            raise ValueError("the journal's scheduler/config has no problem")
        config = config_from_info(info, _settings_of(paths))
        topics = keys.Topics(config.spacecraft)
        snapshot = _opening_snapshot(recorded, topics)
        engine = (
            Engine.restore(engine_config(config), snapshot)
            if snapshot is not None
            else Engine(engine_config(config), info.problem)
        )
        decoder = InputDecoder(
            topics,
            config.clock,
            config.max_clock_step,
            engine.initial.resources,
        )
        return cls(
            recorded,
            info,
            info_topic,
            config,
            topics,
            snapshot,
            engine,
            decoder,
        )


def _opening_snapshot(
    recorded: Sequence[RecordedMessage], topics: keys.Topics
) -> EngineSnapshot | None:
    """The snapshot a journal file starts from, if it has one.

    A node journaling into a state folder (``run --state``) starts each
    file with the engine's state; the messages after it continue from
    there. A snapshot later in a file (a standby's copy) is not a start.
    """
    for message in recorded:
        kind = topics.schema_kind(message.topic)
        if kind == "snapshot":
            return msgspec.json.decode(message.payload, type=EngineSnapshot)
        if kind != "node_info":
            return None
    return None


@dataclass
class Rebuilt:
    """An engine rebuilt from a journal, and where the journal ended.

    Attributes
    ----------
    engine
        In the state the journaled node was in after its last step.
    config
        The node settings the journal was made with.
    last_log_time_ns
        Log time of the journal's last message (wall-clock ns).
    last_tick
        The last time unit seen (ticks or bus clock), None if none.
    messages
        How many journal messages were read after the starting point.
    """

    engine: Engine
    config: NodeConfig
    last_log_time_ns: int = 0
    last_tick: int | None = None
    messages: int = 0


def rebuild(
    paths: PathLike | Sequence[PathLike],
    *,
    solve_fn: SolveFn | None = None,
) -> Rebuilt:
    """Rebuild the engine a journal describes, without solving again.

    The journal is read from its opening snapshot (or from the initial
    problem of ``scheduler/config``); recorded inputs are stepped in
    order and each solve result is taken from its solve record
    (``result``) where the original arrived. Outputs are not compared.
    A solve in flight at the end stays pending in the engine: ask for it
    again with :meth:`Engine.pending_solve`.

    Parameters
    ----------
    paths
        The journal file(s), in order.
    solve_fn
        Used only for solve records without ``result`` (journals written
        before results were recorded).

    Returns
    -------
    Rebuilt
    """
    from .follow import Follower

    start = _Start.of(paths)
    recorded, info_topic = start.recorded, start.info_topic
    follower = Follower(
        start.config, start.snapshot, start.info.problem, solve_fn
    )
    out = Rebuilt(follower.engine, start.config)
    out.last_tick = follower.last_tick
    for message in recorded:
        out.last_log_time_ns = max(out.last_log_time_ns, message.log_time_ns)
        if message.topic == info_topic:
            continue
        if start.topics.schema_kind(message.topic) == "snapshot":
            continue
        out.messages += 1
        follower.apply(message.topic, message.payload)
    out.last_tick = follower.last_tick
    return out


def _term_first(
    inputs: list[RecordedMessage],
    topics: keys.Topics,
    decoder: InputDecoder,
    engine: Engine,
    now: int,
    report: VerifyReport,
    run: Callable[[list], None],
) -> list[RecordedMessage]:
    """Step the term a node began right after its opening snapshot (its
    alarm, if any, is compared too); the rest of ``inputs``."""
    for at, message in enumerate(inputs):
        kind = topics.schema_kind(message.topic)
        if kind == "snapshot":
            continue
        if kind != "term":
            return inputs
        event = decoder.event(message.topic, message.payload)
        if event is not None:
            report.inputs += 1
            run(engine.step(event, now))
        return inputs[:at] + inputs[at + 1 :]
    return inputs


def _outputs_and_inputs(
    recorded: Sequence[RecordedMessage], info_topic: str
) -> Iterator[RecordedMessage]:
    for message in recorded:
        if message.topic != info_topic:
            yield message


def _only_recorded_fields(got: Any, recorded: Any) -> Any:
    """``got`` without the fields the recording does not have.

    Message types only ever gain optional fields; a recording made before a
    field existed is still compared on every field it has.
    """
    if isinstance(got, dict) and isinstance(recorded, dict):
        return {
            k: _only_recorded_fields(v, recorded[k])
            for k, v in got.items()
            if k in recorded
        }
    if isinstance(got, list) and isinstance(recorded, list):
        return [
            _only_recorded_fields(g, r)
            for g, r in zip(got, recorded, strict=False)
        ] + got[len(recorded) :]
    return got


def _rebuild_lifecycle(
    lifecycle: dict[str, str], got: dict[str, Any], expected: Any
) -> None:
    """Follow the lifecycle map through replayed statuses.

    A status with ``activities`` resets the map, ``changed`` updates it;
    a recorded status with the whole map is compared with the rebuilt one.
    """
    if "activities" in got:
        lifecycle.clear()
        lifecycle.update(got["activities"])
    lifecycle.update(got.get("changed", {}))
    if (
        isinstance(expected, dict)
        and "activities" in expected
        and "activities" not in got
    ):
        got["activities"] = dict(sorted(lifecycle.items()))


def _compare(
    report: VerifyReport,
    produced: deque[tuple[str, bytes]],
    message: RecordedMessage,
    kind: str,
) -> bool:
    expected = _normalise(kind, message.payload)
    if not produced:
        report.divergence = Divergence(
            report.outputs,
            message.topic,
            None,
            expected,
            None,
            "the replay did not publish this",
        )
        return False
    key, payload = produced.popleft()
    # One dispatch channel now, one per task in older journals: compared
    # by bus key (a dispatch's task is in the message).
    recorded_key = keys.bus_key(message.topic, message.payload)
    same = key == recorded_key
    got = _normalise(kind, payload)
    if kind == "status" and isinstance(got, dict):
        _rebuild_lifecycle(report.lifecycle, got, expected)
    got = (
        _only_recorded_fields(got, expected)
        if same
        else (msgspec.json.decode(payload))
    )
    if not same or got != expected:
        report.divergence = Divergence(
            report.outputs,
            recorded_key,
            key,
            expected,
            got,
            _first_difference(expected, got) if same else "",
        )
        return False
    report.outputs += 1
    report.plans += kind == "plan"
    report.dispatches += kind == "dispatch"
    report.derived += kind in DERIVED_EXCLUDED
    return True


def _settings_of(paths: PathLike | Sequence[PathLike]) -> dict[str, str]:
    """The ``fsw_scheduler.settings`` metadata of the first journal file
    that has it (empty for a recording that carries none)."""
    files = [paths] if isinstance(paths, (str, os.PathLike)) else paths
    for path in files:
        for name, pairs in read_metadata(path):
            if name == "fsw_scheduler.settings":
                return pairs
    return {}


def _solve_records(
    recorded: Sequence[RecordedMessage], topics: keys.Topics
) -> dict[int, messages.SolveRecord]:
    """Solve id -> its record, as the journal holds them."""
    found = {}
    for message in recorded:
        if topics.schema_kind(message.topic) == "solve_record":
            try:
                record = msgspec.json.decode(
                    message.payload, type=messages.SolveRecord
                )
            except (msgspec.DecodeError, msgspec.ValidationError):
                continue
            found[record.solve_id] = record
    return found


#: Statuses that prove something (re-solving gives them again); the
#: others mean the solve stopped at its limit, which the wall clock sets.
_PROVEN = frozenset({SolveStatus.OPTIMAL, SolveStatus.INFEASIBLE})


def replay_solve(
    solve: SolveFn,
    config: NodeConfig,
    command: StartSolve,
    records: dict[int, messages.SolveRecord],
    report: VerifyReport,
) -> Plan:
    """A solve of the replay: again, or the recorded one where the wall
    clock decided it (said per solve in ``report.notes``).

    * A solve that proved its result (optimal, infeasible) is solved
      again, with the limit the node gave it, and must give the same.
    * A solve that stopped at its limit (feasible, unknown) depended on
      the machine's speed: its recorded plan is checked with the
      independent checker and reused.
    * An explanation cut by its time budget (``not_analysed``) is taken
      from the record when the plan itself is the same.
    * A solve recorded ``optimal`` that, run again, holds nothing better
      (no proof in its limit here, or another plan of the same
      objective: the proof came after steps the clock ended) has its
      recorded plan checked and reused, and one recorded ``infeasible``
      that gives ``unknown`` is reused (:func:`_no_better`); a better
      plan, or a plan where none was, is a divergence.
    """
    record = records.get(command.solve_id)
    recorded = record.result if record is not None else None
    if recorded is None:
        return solve(config, command)
    limit = recorded.stats.time_limit_s if recorded.stats else None
    if recorded.status not in _PROVEN:
        issues = (
            []
            if not recorded.activities
            else _check(command, recorded, config)
        )
        if not issues:
            report.notes.append(
                f"solve {command.solve_id} ({command.trigger}) stopped at "
                f"its limit ({limit} s) when recorded: its "
                f"{recorded.status.value} plan passes the checker and is "
                "reused, not re-solved"
            )
            return recorded
        report.notes.append(
            f"solve {command.solve_id}: the recorded plan fails the "
            f"checker ({issues[0]}): solved again"
        )
    given = config if limit is None else config.replace(time_limit=limit)
    plan = solve(given, command)
    budget_cut = any(
        b.cause == "not_analysed" for b in (*plan.why, *recorded.why)
    )
    # The same plan: timings aside (stats), and the explanation aside.
    same = plan.replace(why=(), stats=None) == recorded.replace(
        why=(), stats=None
    )
    if budget_cut and same:
        if plan.why != recorded.why:
            report.notes.append(
                f"solve {command.solve_id}: same plan; its explanation was "
                "cut by its time budget: the recorded one is reused"
            )
        return plan.replace(why=recorded.why)
    if not same and _no_better(plan, recorded):
        checked = bool(recorded.activities)
        if not checked or not _check(command, recorded, config):
            report.notes.append(
                f"solve {command.solve_id} ({command.trigger}) proved "
                f"{_said(recorded)} when recorded on a path the clock "
                f"decided; solved again in its limit ({limit} s): "
                f"{_said(plan)}, nothing better: the recorded answer is "
                "reused" + (" (it passes the checker)" if checked else "")
            )
            return recorded
    return plan


def _said(plan: Plan) -> str:
    total = f" {plan.objective.total}" if plan.objective else ""
    return plan.status.value + total


def _no_better(plan: Plan, recorded: Plan) -> bool:
    """True if ``plan``, a proved solve run again, holds nothing that
    contradicts ``recorded``: for an ``optimal`` record, no plan, a worse
    one (stopped at its limit on this run) or another of the same
    objective; for an ``infeasible`` one, no answer (``unknown``).

    A proof can come after steps the clock ends (a relaxation interrupted
    at its deadline, a search that ran so many rounds), so run again it
    may stop short of the proof or end on another of equal optima; only
    a strictly better plan, or a plan where none was, contradicts the
    recording.
    """
    if recorded.status is SolveStatus.INFEASIBLE:
        return plan.status is SolveStatus.UNKNOWN
    if recorded.status is not SolveStatus.OPTIMAL or not recorded.objective:
        return False
    if plan.status is SolveStatus.INFEASIBLE:
        return False
    return plan.objective is None or (
        plan.objective.total >= recorded.objective.total
    )


def _verify_what_if(
    message: RecordedMessage,
    states: dict[int, EngineSnapshot],
    engine: Engine,
    config: NodeConfig,
    solve: SolveFn,
    report: VerifyReport,
) -> bool:
    """Answer a journaled what-if again and compare (False: a divergence,
    in ``report``); see :mod:`.whatifs`. Its solves are checked like any
    solve (:func:`replay_solve`, with the what-if's own records)."""
    record = msgspec.json.decode(message.payload, type=messages.WhatIfRecord)
    engine.note_what_if()
    report.what_ifs += 1
    own = {r.solve_id: r for r in record.solves}

    def run(command: StartSolve) -> Plan:
        return replay_solve(solve, config, command, own, report)

    got = answer_again(record, states, engine.config, run)
    if isinstance(got, str):
        report.notes.append(got)
        return True
    expected, replayed = comparable(record.answer), comparable(got)
    if expected == replayed:
        return True
    report.divergence = Divergence(
        report.outputs,
        message.topic,
        message.topic,
        expected,
        replayed,
        "what-if answer: " + _first_difference(expected, replayed),
    )
    return False


def _check(command: StartSolve, plan: Plan, config: NodeConfig) -> list[str]:
    from ..analysis.check import check_plan
    from ..runtime.policy import stability_of

    stability = stability_of(config, command)
    result = check_plan(command.problem, plan, stability)
    return [str(v) for v in result.violations] if not result.ok else []
