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
``counters.inputs_dropped`` (a property of the live inbox) and status
replies to queries (never recorded). Everything else must match: plan ids,
activities, unscheduled tasks and reasons, objectives, dispatch times and
contents, lifecycle states, rejection messages. Fields that a newer
version added and the recording does not have are not compared, so old
recordings keep verifying as message types grow.

Derived channels (``scheduler/profiles``, ``scheduler/levels``,
``scheduler/log``, see :mod:`fsw_scheduler.foxglove`) are checked, not
ignored: when the journal has any of them, the replay derives them from
its own stream with the same :class:`~fsw_scheduler.foxglove.Annotator`
and compares them in place like any output (``foxglove.Log``
``timestamp``, a wall-clock time, excepted). Journals recorded before
these channels existed have none and are verified without them.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import msgspec

from . import messages
from .bus import topics as keys
from .config import NodeConfig
from .engine import Engine, Publish, SolveDone, StartSolve
from .foxglove import DERIVED, Annotator, engine_problem
from .inputs import InputDecoder
from .recording import PathLike, RecordedMessage, iter_messages
from .solution import Plan

#: Fields left out of the comparison, per output kind (dotted paths).
EXCLUDED: dict[str, tuple[str, ...]] = {
    "plan": ("stats",),
    "status": ("counters.inputs_dropped", "last_solve.wall_s"),
    "solve_record": (
        "build_s",
        "solve_s",
        "wall_s",
        "num_variables",
        "num_constraints",
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
    divergence: Divergence | None = None
    notes: list[str] = field(default_factory=list)

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
    raise ValueError(
        "no scheduler/config message: not a scheduler journal "
        "(record with 'fsw-scheduler run --record' or 'demo')"
    )


def config_from_info(info: messages.NodeInfo) -> NodeConfig:
    """The node configuration a journal was made with."""
    return NodeConfig(
        spacecraft=info.spacecraft,
        solver=info.solver,  # type: ignore[arg-type]
        time_limit=info.time_limit_s,
        seed=info.seed,
        explain=info.explain,
        explain_budget=info.explain_budget,
        clock=info.clock,  # type: ignore[arg-type]
        report_timeout=info.report_timeout,
        drift_absolute=info.drift_absolute,
        drift_relative=info.drift_relative,
        heartbeat=info.heartbeat,
        replan_lead=info.replan_lead,
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
    from .bus.node import engine_config, run_solve

    recorded = list(iter_messages(paths))
    info, info_topic = read_node_info(recorded)
    if info.problem is None:
        raise ValueError("the journal's scheduler/config has no problem")
    config = config_from_info(info)
    topics = keys.Topics(config.spacecraft)
    engine = Engine(engine_config(config), info.problem)
    decoder = InputDecoder(topics, config.clock)
    solve = solve_fn or run_solve
    report = VerifyReport()
    produced: deque[tuple[str, bytes]] = deque()
    results: dict[int, Plan] = {}
    now = 0
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
                results[command.solve_id] = solve(config, command)

    for message in _outputs_and_inputs(recorded, info_topic):
        kind = topics.schema_kind(message.topic)
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
            now = max(now, event.now)  # type: ignore[attr-defined]
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
    got = (
        _only_recorded_fields(_normalise(kind, payload), expected)
        if key == message.topic
        else (msgspec.json.decode(payload))
    )
    if key != message.topic or got != expected:
        report.divergence = Divergence(
            report.outputs,
            message.topic,
            key,
            expected,
            got,
            _first_difference(expected, got) if key == message.topic else "",
        )
        return False
    report.outputs += 1
    report.plans += kind == "plan"
    report.dispatches += kind == "dispatch"
    report.derived += kind in DERIVED_EXCLUDED
    return True
