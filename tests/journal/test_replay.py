"""Tests of ``replay --verify`` on the golden journals and altered copies."""

from __future__ import annotations

import json
import shutil
import subprocess
from typing import TYPE_CHECKING, Any, NamedTuple

import pytest
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import Writer

from fsw_scheduler.app.demo import run_demo
from fsw_scheduler.journal.replay import DERIVED_EXCLUDED, EXCLUDED, verify
from fsw_scheduler.wire.topics import Topics

from ..factories import ROOT, cli_command

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

REPLAY_DIR = ROOT / "replay"
GOLDEN_FILES = sorted(REPLAY_DIR.glob("*.mcap"))
# The tampering tests edit the paper recording made by 0.1.0 (no derived
# channels, full lifecycle maps in statuses): every message there is one
# the tests reason about. The current recordings verify in
# test_golden_journal_verifies.
PAPER = REPLAY_DIR / "paper-2026-11-26.mcap"
TOPICS = Topics()


class Row(NamedTuple):
    """One message of a journal, as rewritten by the tests."""

    topic: str
    data: bytes
    log_time: int
    publish_time: int


def fsw_scheduler(*args: str) -> subprocess.CompletedProcess[str]:
    """Run the ``fsw-scheduler`` script of this environment."""
    return subprocess.run(
        cli_command(*args),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def read_rows(path: Path) -> list[Row]:
    """Every message of ``path`` in log-time order."""
    with open(path, "rb") as f:
        return [
            Row(channel.topic, m.data, m.log_time, m.publish_time)
            for _schema, channel, m in make_reader(f).iter_messages(
                log_time_order=True
            )
        ]


def rewrite(
    src: Path, dst: Path, edit: Callable[[list[Row]], list[Row]]
) -> None:
    """Copy a journal through the mcap reader and writer, editing rows.

    Channels and schemas are carried over unchanged; an edited row may
    only use a topic that ``src`` already has.
    """
    with open(src, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    channels = {ch.topic: ch for ch in summary.channels.values()}
    rows = edit(read_rows(src))
    with open(dst, "wb") as f:
        writer = Writer(f)
        writer.start(profile="", library="tests.test_replay")
        schema_ids: dict[int, int] = {0: 0}
        channel_ids: dict[str, int] = {}
        for row in rows:
            if row.topic not in channel_ids:
                channel = channels[row.topic]
                if channel.schema_id not in schema_ids:
                    schema = summary.schemas[channel.schema_id]
                    schema_ids[channel.schema_id] = writer.register_schema(
                        schema.name, schema.encoding, schema.data
                    )
                channel_ids[row.topic] = writer.register_channel(
                    row.topic,
                    channel.message_encoding,
                    schema_ids[channel.schema_id],
                )
            writer.add_message(
                channel_ids[row.topic],
                log_time=row.log_time,
                data=row.data,
                publish_time=row.publish_time,
            )
        writer.finish()


def kind(row: Row) -> str | None:
    """The message kind of a row (``plan``, ``dispatch``...)."""
    return TOPICS.schema_kind(row.topic)


def output_index(rows: list[Row], position: int) -> int:
    """How many compared outputs come before ``rows[position]``."""
    compared = {*EXCLUDED, *DERIVED_EXCLUDED}
    return sum(kind(row) in compared for row in rows[:position])


def first(rows: list[Row], wanted: str, after: int = 0) -> int:
    """Position of the first row of kind ``wanted`` from ``after`` on."""
    return next(i for i in range(after, len(rows)) if kind(rows[i]) == wanted)


def edited(row: Row, change: Callable[[dict], None]) -> Row:
    """``row`` with its JSON payload changed in place by ``change``."""
    doc = json.loads(row.data)
    change(doc)
    return row._replace(data=json.dumps(doc).encode())


@pytest.fixture(scope="module")
def paper_rows() -> list[Row]:
    """The messages of the paper golden journal."""
    return read_rows(PAPER)


# -- golden files ------------------------------------------------------------


def test_golden_directory_has_journals() -> None:
    """Tests that replay/ holds the paper and failure golden journals."""
    names = {path.name for path in GOLDEN_FILES}
    assert {"paper.mcap", "failure.mcap"} <= names


@pytest.mark.parametrize(
    "path", GOLDEN_FILES or [None], ids=lambda p: p.name if p else "none"
)
def test_golden_journal_verifies(path: Path | None) -> None:
    """Tests that every journal in replay/ replays identically."""
    assert path is not None, "no *.mcap file in replay/"
    report = verify(path)
    assert report.identical, report.summary()
    assert report.plans >= 1
    assert report.dispatches >= 1
    assert report.inputs >= 1


@pytest.mark.parametrize(
    "path", GOLDEN_FILES or [None], ids=lambda p: p.name if p else "none"
)
def test_golden_journal_reads_with_schemas(path: Path | None) -> None:
    """Tests that the mcap reader yields every golden message with schema."""
    assert path is not None, "no *.mcap file in replay/"
    count = 0
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            count += 1
            assert channel.message_encoding == MessageEncoding.JSON
            assert schema is not None, channel.topic
            assert schema.encoding == SchemaEncoding.JSONSchema
            assert isinstance(json.loads(schema.data), dict)
            json.loads(message.data)
    assert count > 0
    assert path.stat().st_size < 200_000


def test_failure_journal_has_failure_and_drift() -> None:
    """Tests that the failure journal holds a failed activity and drift."""
    path = REPLAY_DIR / "failure.mcap"
    rows = read_rows(path)
    reports = [
        json.loads(r.data) for r in rows if kind(r) == "activity_report"
    ]
    assert any(r["state"] == "failed" for r in reports)
    triggers = {
        json.loads(r.data).get("trigger")
        for r in rows
        if kind(r) == "solve_record"
    }
    assert "drift" in triggers


# -- altered journals are caught --------------------------------------------


def test_changed_dispatch_start_is_caught(
    tmp_path: Path, paper_rows: list[Row]
) -> None:
    """Tests that a dispatch with another start diverges on field start."""
    at = first(paper_rows, "dispatch")
    original = json.loads(paper_rows[at].data)["start"]

    def shift(rows: list[Row]) -> list[Row]:
        rows[at] = edited(rows[at], lambda d: d.update(start=original + 3))
        return rows

    altered = tmp_path / "altered.mcap"
    rewrite(PAPER, altered, shift)
    report = verify(altered)
    divergence = report.divergence
    assert divergence is not None
    assert divergence.index == output_index(paper_rows, at)
    assert divergence.key_recorded == divergence.key_replayed
    assert divergence.key_recorded == paper_rows[at].topic
    assert divergence.field == "start"
    assert divergence.recorded["start"] == original + 3
    assert divergence.replayed["start"] == original


def test_moved_plan_activity_is_caught(
    tmp_path: Path, paper_rows: list[Row]
) -> None:
    """Tests that a plan with one activity moved diverges on that activity."""
    at = first(paper_rows, "plan")
    plan = json.loads(paper_rows[at].data)
    idx = 2
    start, end = (plan["activities"][idx][k] for k in ("start", "end"))

    def move(doc: dict) -> None:
        doc["activities"][idx].update(start=start + 1, end=end + 1)

    def edit(rows: list[Row]) -> list[Row]:
        rows[at] = edited(rows[at], move)
        return rows

    altered = tmp_path / "altered.mcap"
    rewrite(PAPER, altered, edit)
    divergence = verify(altered).divergence
    assert divergence is not None
    assert divergence.index == output_index(paper_rows, at)
    assert divergence.key_recorded == TOPICS.key("scheduler/plan")
    assert divergence.key_replayed == divergence.key_recorded
    # Keys are compared in sorted order: "end" comes before "start".
    assert divergence.field == f"activities[{idx}].end"
    assert divergence.recorded["activities"][idx]["start"] == start + 1
    assert divergence.replayed["activities"][idx]["start"] == start
    assert divergence.replayed["activities"][idx]["end"] == end


def test_deleted_output_is_caught(
    tmp_path: Path, paper_rows: list[Row]
) -> None:
    """Tests that a deleted dispatch shows as the replay's extra output."""
    at = first(paper_rows, "dispatch")
    deleted = paper_rows[at]
    after = next(
        i
        for i in range(at + 1, len(paper_rows))
        if kind(paper_rows[i]) in EXCLUDED
    )

    def delete(rows: list[Row]) -> list[Row]:
        return rows[:at] + rows[at + 1 :]

    altered = tmp_path / "altered.mcap"
    rewrite(PAPER, altered, delete)
    divergence = verify(altered).divergence
    assert divergence is not None
    assert divergence.index == output_index(paper_rows, at)
    assert divergence.key_replayed == deleted.topic
    recorded = json.loads(deleted.data)
    # Fields newer than the recording (dispatch_id) are not compared.
    assert {
        k: v for k, v in divergence.replayed.items() if k in recorded
    } == recorded
    assert divergence.key_recorded == paper_rows[after].topic
    assert divergence.recorded == json.loads(paper_rows[after].data)
    assert divergence.field == ""


def test_extra_input_is_caught(tmp_path: Path, paper_rows: list[Row]) -> None:
    """Tests that an extra failure report diverges on that activity."""
    # The first report of a running activity, then its status output: the
    # extra report goes right after that status.
    report_at = first(paper_rows, "activity_report")
    report = paper_rows[report_at]
    task = json.loads(report.data)["task"]
    status_at = first(paper_rows, "status", report_at)
    nxt = paper_rows[status_at + 1]
    extra = edited(
        report._replace(
            log_time=(paper_rows[status_at].log_time + nxt.log_time) // 2
        ),
        lambda d: d.update(state="failed"),
    )
    extra = extra._replace(publish_time=extra.log_time)

    def insert(rows: list[Row]) -> list[Row]:
        return [*rows[: status_at + 1], extra, *rows[status_at + 1 :]]

    altered = tmp_path / "altered.mcap"
    rewrite(PAPER, altered, insert)
    assert read_rows(altered)[status_at + 1] == extra
    divergence = verify(altered).divergence
    assert divergence is not None
    assert divergence.index == output_index(paper_rows, status_at + 1)
    assert divergence.key_replayed == TOPICS.key("scheduler/status")
    assert divergence.replayed["activities"][task] == "failed"
    assert divergence.recorded["activities"][task] == "running"
    assert divergence.field == f"activities.{task}"


def test_cli_verify_exit_codes(tmp_path: Path, paper_rows: list[Row]) -> None:
    """Tests that replay --verify exits 1 on divergence and 0 on golden."""
    at = first(paper_rows, "dispatch")

    def shift(rows: list[Row]) -> list[Row]:
        rows[at] = edited(rows[at], lambda d: d.update(start=d["start"] + 3))
        return rows

    altered = tmp_path / "altered.mcap"
    rewrite(PAPER, altered, shift)
    bad = fsw_scheduler("replay", str(altered), "--verify")
    assert bad.returncode == 1, bad.stderr
    assert "DIVERGED" in bad.stdout
    index = output_index(paper_rows, at)
    assert f"output #{index} differs (field start)" in bad.stdout
    topic = paper_rows[at].topic
    assert f"recorded: {topic} " in bad.stdout
    assert f"replayed: {topic} " in bad.stdout
    good = fsw_scheduler("replay", str(PAPER), "--verify")
    assert good.returncode == 0, good.stdout + good.stderr
    assert "IDENTICAL" in good.stdout


def test_altered_copy_leaves_golden_intact(tmp_path: Path) -> None:
    """Tests that an unedited rewrite of a golden journal still verifies."""
    copy = tmp_path / "copy.mcap"
    shutil.copyfile(PAPER, copy)
    rewritten = tmp_path / "rewritten.mcap"
    rewrite(copy, rewritten, lambda rows: rows)
    assert read_rows(rewritten) == read_rows(PAPER)
    assert verify(rewritten).identical


# -- a fresh run ------------------------------------------------------------


def test_fresh_demo_journal_verifies(tmp_path: Path) -> None:
    """Tests that a new demo run's journal replays identically."""
    result = run_demo(tmp_path, quiet=True, pictures=False, verify=False)
    assert result.journal.exists()
    report = verify(result.journal)
    assert report.identical, report.summary()
    assert report.plans >= 2


@pytest.mark.slow
def test_a_session_whose_solves_stop_at_their_limit_verifies(
    tmp_path: Path,
) -> None:
    """Tests ``replay --verify`` on a real node's journal whose solves
    stopped at a 1 s limit: IDENTICAL, and the report says, per solve,
    that the recorded plan passed the checker and was reused."""
    import json

    from fsw_scheduler.journal.replay import verify
    from fsw_scheduler.journal.state import journal_files
    from fsw_scheduler.testing import SchedulerClient

    from ..factories import bench_lib
    from .test_resume import soak_resume

    problem = tmp_path / "big.json"
    doc = bench_lib("generator").generate_problem(80, "mixed", 336, 7)
    problem.write_text(json.dumps(doc))
    soak = soak_resume()
    router, port = soak.start_router()
    node = soak.SchedulerProcess(
        [
            "--problem",
            str(problem),
            "--clock",
            "bus",
            "--state",
            str(tmp_path / "state"),
            "--connect",
            f"tcp/127.0.0.1:{port}",
            "--no-multicast-scouting",
            "--insecure",
            "--no-standby",
            "--time-limit",
            "1",
            "-m",
            "client",
        ]
    )
    try:
        import zenoh

        from fsw_scheduler.bus.session import loopback_config

        config = loopback_config(
            listen=None, connect=[f"tcp/127.0.0.1:{port}"]
        )
        config.insert_json5("mode", '"client"')
        with zenoh.open(config) as session:
            client = SchedulerClient(session, timeout=60.0)
            node.start()
            client.wait_scheduler(60)
            client.tick(0)
            plan = client.wait_plan(lambda p: p.plan_id == 1, 60)
            assert plan.status.value == "feasible", plan.status
            client.tick(1)
            client.close()
    finally:
        node.stop()
        router.close()
    (journal,) = journal_files(tmp_path / "state")
    report = verify(journal)
    assert report.identical, report.summary()
    assert any("stopped at its limit" in n for n in report.notes), report.notes


def test_a_budget_cut_explanation_is_taken_from_the_record() -> None:
    """Tests replay_solve on a recorded plan whose explanation ran out of
    its budget: the same plan (timings aside) gets the recorded ``why``,
    and the report says so."""
    from fsw_scheduler.engine.events import StartSolve
    from fsw_scheduler.journal.replay import VerifyReport, replay_solve
    from fsw_scheduler.model.plan import Blocker, SolverStats
    from fsw_scheduler.runtime.config import NodeConfig
    from fsw_scheduler.runtime.policy import run_solve
    from fsw_scheduler.wire import messages

    from ..engine.driver import paper

    command = StartSolve(1, "initial", paper(), None)
    config = NodeConfig(explain=False)
    recorded = run_solve(config, command).replace(
        why=(Blocker("SetPositionX", "not_analysed", "out of time"),),
        stats=SolverStats("cbc", wall_s=99.0),
    )
    record = messages.SolveRecord(
        1, "initial", "", paper(), recorded.status, result=recorded
    )
    report = VerifyReport()
    plan = replay_solve(run_solve, config, command, {1: record}, report)
    assert plan.why == recorded.why
    assert any("cut by its time budget" in n for n in report.notes)


def test_a_part_killed_as_it_opened_verifies_with_a_note(
    tmp_path: Path,
) -> None:
    """Tests that a journal part whose writer was killed right after it
    opened it (only the MCAP header on disk, as a kill just after a
    rotation leaves it) verifies as holding no decision, with a note,
    instead of failing as 'not a scheduler journal'."""
    from fsw_scheduler.journal.recover import recover

    source = REPLAY_DIR / sorted(p.name for p in GOLDEN_FILES)[-1]
    cut = tmp_path / "cut.mcap"
    # The magic and the header record: what the writer puts on disk when
    # it opens a part, before the first chunk is flushed.
    with open(source, "rb") as stream:
        head = stream.read(8)
        opcode = stream.read(1)
        length = int.from_bytes(stream.read(8), "little")
        cut.write_bytes(
            head + opcode + length.to_bytes(8, "little") + stream.read(length)
        )
    finished = tmp_path / "finished.mcap"
    assert recover(cut, finished) == {}
    report = verify(finished)
    assert report.identical
    assert report.outputs == 0
    assert any("holds no message" in note for note in report.notes)
    # A journal with messages but no settings is still refused.
    with pytest.raises(Exception, match="no scheduler/config"):
        verify(_journal_without_config(tmp_path))


def _journal_without_config(tmp_path: Path) -> Path:
    """A journal of one clock message and no ``scheduler/config``."""
    path = tmp_path / "no-config.mcap"
    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start()
        schema = writer.register_schema(
            "clock", SchemaEncoding.JSONSchema, b"{}"
        )
        channel = writer.register_channel(
            TOPICS.key("clock"), MessageEncoding.JSON, schema
        )
        writer.add_message(channel, 1, b'{"now": 1}', 1)
        writer.finish()
    return path


def test_an_overrun_session_replays_identical(tmp_path: Path) -> None:
    """Tests a recorded session on a real node with ``late-completion``
    ``push`` in which SetPositionK runs until 9 instead of 7: its tight
    successor is commanded only after it (at 9), the ``overrun`` replan
    is in the journal, the setting comes back from its metadata and
    replay --verify reproduces every plan and dispatch."""
    from fsw_scheduler.journal.annotate import schema_lookup
    from fsw_scheduler.journal.writer import Recorder
    from fsw_scheduler.testing import (
        SchedulerHarness,
        harness_config,
        paper_problem,
    )

    journal = tmp_path / "overrun.mcap"
    recorder = Recorder(journal, schemas=schema_lookup("sat1"))
    config = harness_config(late_completion="push")
    ends = {"SetPositionK": 9}
    with SchedulerHarness(
        paper_problem(), config, node_options={"journal": recorder}
    ) as h:
        running: dict[str, int] = {}
        for now in range(12):
            h.tick(now)
            h.settle(now)
            # The executor answers after the clock message: completions
            # race it, as on a real bus.
            while True:
                for d in h.dispatches:
                    if d.task not in running and d.action == "run":
                        running[d.task] = ends.get(
                            d.task, now + d.end - d.start
                        )
                done = [t for t, end in sorted(running.items()) if end == now]
                if not done:
                    break
                for task in done:
                    h.report(task, "completed", now)
                    running[task] = -1
                h.settle(now)
        starts = {d.task: d.dispatched_at for d in h.dispatches}
        triggers = [p.trigger for p in h.plans]
    assert starts["BatteryCharge"] == 9
    assert "overrun" in triggers
    report = verify(journal)
    assert report.identical, report.summary()


def _twins() -> tuple[Any, Any, Any]:
    """Two equal tasks sharing a camera, solved (optimal): the command,
    the config and the recorded plan; either order is an optimum."""
    from fsw_scheduler.engine.events import StartSolve
    from fsw_scheduler.runtime.config import NodeConfig
    from fsw_scheduler.runtime.policy import run_solve

    from ..factories import make_doc, make_task, problem_from

    problem = problem_from(
        make_doc(
            [
                make_task("a", 3, uses={"camera": 1}),
                make_task("b", 3, uses={"camera": 1}),
            ],
            resources={"binary": ["camera"]},
        )
    )
    command = StartSolve(1, "initial", problem, None)
    config = NodeConfig(explain=False)
    return command, config, run_solve(config, command)


def _swapped(problem: Any, plan: Any, shift: int = 0) -> Any:
    """``plan`` with its two activities' starts swapped (``shift`` more
    units for the later one), a valid plan of ``problem`` with the
    checker's objective."""
    import msgspec

    from fsw_scheduler.analysis.check import check_plan

    first, second = sorted(plan.activities, key=lambda a: a.start)

    def moved(activity: Any, start: int) -> Any:
        length = activity.end - activity.start
        return msgspec.structs.replace(
            activity, start=start, end=start + length
        )

    swapped = plan.replace(
        activities=(
            moved(second, first.start),
            moved(first, second.start + shift),
        )
    )
    report = check_plan(problem, swapped.replace(objective=None))
    assert report.ok, report
    return swapped.replace(objective=report.objective)


def test_a_proof_met_again_with_another_optimum_reuses_the_record() -> None:
    """Tests replay_solve on a solve recorded ``optimal`` whose re-solve
    ends on another plan of the same objective (a proof can come after
    steps the clock ends, and equal optima differ by the path): the
    recorded plan is checked and reused, and the report says why."""
    from fsw_scheduler.journal.replay import VerifyReport, replay_solve
    from fsw_scheduler.model.plan import SolveStatus
    from fsw_scheduler.runtime.policy import run_solve
    from fsw_scheduler.wire import messages

    command, config, solved = _twins()
    assert solved.status is SolveStatus.OPTIMAL
    recorded = _swapped(command.problem, solved)
    assert recorded.starts() != solved.starts()
    assert recorded.objective == solved.objective
    record = messages.SolveRecord(
        1, "initial", "", command.problem, recorded.status, result=recorded
    )
    report = VerifyReport()
    plan = replay_solve(run_solve, config, command, {1: record}, report)
    assert plan.starts() == recorded.starts()
    assert any(
        "proved optimal" in n and "recorded answer is reused" in n
        for n in report.notes
    ), report.notes


def test_a_recorded_proof_beaten_again_is_not_reused() -> None:
    """Tests that a solve recorded ``optimal`` whose re-solve finds a
    better plan is not reused: the re-solved plan comes back (and the
    comparison then diverges), whatever the checker says of the record."""
    from fsw_scheduler.journal.replay import VerifyReport, replay_solve
    from fsw_scheduler.runtime.policy import run_solve
    from fsw_scheduler.wire import messages

    command, config, solved = _twins()
    recorded = _swapped(command.problem, solved, shift=1)  # a unit later
    record = messages.SolveRecord(
        1, "initial", "", command.problem, recorded.status, result=recorded
    )
    report = VerifyReport()
    assert recorded.objective.total > solved.objective.total
    plan = replay_solve(run_solve, config, command, {1: record}, report)
    assert plan.starts() == solved.starts()
    assert not report.notes


def _two_lanes() -> Any:
    """Six mandatory tasks of 30-40 on a capacity of 100 (at most two or
    three at once) in a window too short for them: infeasible, which CBC
    proves (no proof of the product's catches it)."""
    from ..factories import make_doc, make_task, problem_from

    return problem_from(
        make_doc(
            [
                make_task(
                    f"h{i}",
                    8,
                    schedule_cost=0,
                    uses={"power": amount},
                    feasible_interval=[0, 23],
                )
                for i, amount in enumerate([40, 35, 30, 40, 35, 30])
            ],
            horizon=40,
            resources={"multiple": {"power": 100}},
            feasible_interval_applies_to="task",
        )
    )


def test_an_infeasibility_not_proved_again_in_time_is_reused() -> None:
    """Tests that a solve recorded ``infeasible`` that, run again in its
    recorded limit, stops without an answer (``unknown``: the proof took
    longer here) reuses the recorded answer with a note, and that one
    whose re-solve finds a plan is not reused."""
    import msgspec

    from fsw_scheduler.engine.events import StartSolve
    from fsw_scheduler.journal.replay import VerifyReport, replay_solve
    from fsw_scheduler.model.plan import SolveStatus
    from fsw_scheduler.runtime.config import NodeConfig
    from fsw_scheduler.runtime.policy import run_solve
    from fsw_scheduler.wire import messages

    command = StartSolve(1, "initial", _two_lanes(), None)
    config = NodeConfig(explain=False)
    proved = run_solve(config, command)
    assert proved.status is SolveStatus.INFEASIBLE
    assert proved.stats is not None
    recorded = proved.replace(
        stats=msgspec.structs.replace(proved.stats, time_limit_s=0.01)
    )
    record = messages.SolveRecord(
        1, "initial", "", command.problem, recorded.status, result=recorded
    )
    report = VerifyReport()
    plan = replay_solve(run_solve, config, command, {1: record}, report)
    assert plan is recorded
    assert any("proved infeasible when recorded" in n for n in report.notes)

    # A feasible problem recorded as infeasible: the re-solve's plan.
    twins, _, solved = _twins()
    forged = solved.replace(
        status=SolveStatus.INFEASIBLE, activities=(), objective=None
    )
    record = messages.SolveRecord(
        1, "initial", "", twins.problem, forged.status, result=forged
    )
    report = VerifyReport()
    plan = replay_solve(run_solve, config, twins, {1: record}, report)
    assert plan.status is SolveStatus.OPTIMAL
    assert not report.notes
