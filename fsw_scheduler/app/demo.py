"""The paper scenario end to end on an in-process Zenoh bus.

Two loopback peers stand for two computers: one runs the scheduler node,
the other the rest of the spacecraft as seen by the scheduler:

* a clock publishing ``fsw/<sc>/clock`` one unit at a time; it moves on
  only when the scheduler has caught up (a status query says it saw the
  tick and no solve is running), so the session is the same on a slow
  machine and its journal replays exactly;
* a simulated executor that runs dispatched activities, reports them on
  ``telemetry/activities/<task>`` (running, then completed or failed) and
  reports battery levels on ``telemetry/resources/<name>``;
* a goal source sending the paper's Table 2 goal at t=15.

The scheduler journals every input and output to MCAP. At the end the demo
draws each plan, prints the timeline, and replays the journal to prove the
scheduler makes the same decisions again.
"""

from __future__ import annotations

import json
import logging
import queue
import sys
import time
from dataclasses import dataclass, field
from importlib import resources
from typing import TYPE_CHECKING, Any, TextIO

import msgspec
import zenoh

from ..bus.client import Fence
from ..bus.node import SchedulerNode
from ..bus.session import open_peer_pair, wait_matching
from ..journal.annotate import schema_lookup
from ..journal.writer import Recorder
from ..model.plan import Activity, Plan
from ..model.problem import Problem, decode_problem
from ..runtime.config import NodeConfig
from ..wire import messages
from ..wire import topics as keys

if TYPE_CHECKING:
    from pathlib import Path

log = logging.getLogger("fsw_scheduler.demo")

JSON = zenoh.Encoding.APPLICATION_JSON


def scenario_file(name: str) -> bytes:
    """A file shipped with the package (the paper's scenarios)."""
    return resources.files("fsw_scheduler").joinpath("data", name).read_bytes()


@dataclass
class Scenario:
    """What the simulated world does.

    Attributes
    ----------
    goals
        Time unit -> goal JSON sent then.
    failures
        Task -> units after its start at which the executor reports it
        failed (the first run only).
    battery_drift
        Extra battery drain per unit beyond the plan (sensor truth).
    level_every
        Units between battery level reports.
    until
        Last time unit of the session.
    drift_absolute
        Level departure (units) that makes the scheduler replan.
    problem
        The package data file of the problem flown.
    forecasts
        Time unit -> (resource, forecast fields) sent then on
        ``telemetry/resources/<name>/forecast``.
    """

    goals: dict[int, bytes] = field(default_factory=dict)
    failures: dict[str, int] = field(default_factory=dict)
    battery_drift: float = 0.0
    level_every: int = 5
    until: int = 66
    drift_absolute: float = 0.5
    problem: str = "paper_table1.json"
    forecasts: dict[int, tuple[str, dict[str, Any]]] = field(
        default_factory=dict
    )


def paper_scenario() -> Scenario:
    """Table 1 at t=0, the Table 2 goal at t=15."""
    return Scenario(goals={15: scenario_file("paper_table2_goal.json")})


def failure_scenario() -> Scenario:
    """The paper scenario plus a failed downlink and a draining battery."""
    return Scenario(
        goals={15: scenario_file("paper_table2_goal.json")},
        failures={"DownlinkSat2Ground": 4},
        battery_drift=0.2,
        drift_absolute=1.5,
        until=80,
    )


def orbit_scenario() -> Scenario:
    """An Earth-observation day (examples/orbit.json): three orbits, HF or
    LF per target; at t=100 a forecast of a longer eclipse over T3."""
    eclipse = [[100, 100], [118, 60], [140, 100], [157, 60], [190, 100]]
    return Scenario(
        problem="orbit.json",
        forecasts={
            100: ("power", {"at": 100, "steps": [*eclipse, [252, 60]]})
        },
        level_every=20,
        until=240,
    )


SCENARIOS = {
    "paper": paper_scenario,
    "failure": failure_scenario,
    "orbit": orbit_scenario,
}


class Executor:
    """A simulated spacecraft executing dispatched activities.

    It runs each dispatched activity for its planned length from the unit
    it was dispatched, reports ``running`` then ``completed`` (or
    ``failed``), each echoing the dispatch's ``dispatch_id`` and ``term``,
    and keeps the true consumable levels, which it reports. A cancel
    (``action: cancel``) stops the activity it names, or keeps it from
    starting, and is answered ``cancelled``: the README's receiver rules.
    """

    def __init__(self, problem: Problem, scenario: Scenario) -> None:
        self.problem = problem
        self.levels = problem.resources.initial_levels
        self.ceilings = problem.resources.ceilings
        self.scenario = scenario
        self.running: dict[str, tuple[int, int, dict[str, float]]] = {}
        self.commands: dict[str, messages.Dispatch] = {}
        self.last_reports: dict[str, messages.ActivityReport] = {}
        self.executed: list[Activity] = []
        self.failed_once: set[str] = set()

    def on_dispatch(self, dispatch: messages.Dispatch, now: int) -> list:
        """Start (or cancel) an activity; returns reports to publish."""
        task = dispatch.task
        if dispatch.action == "cancel":
            running = self.commands.get(task)
            if (
                running is not None
                and running.dispatch_id != dispatch.dispatch_id
            ):
                return []  # a newer command of the task stands
            if task in self.running:
                start, _, _ = self.running.pop(task)
                self.executed.append(Activity(task, start, now))
            elif running is not None and running.action != "cancel":
                return []  # it ended, and said so already
            self.commands[task] = dispatch
            return [self._report(dispatch, "cancelled", now)]
        length = dispatch.end - dispatch.start
        self.running[task] = (now, now + length, dispatch.uses)
        self.commands[task] = dispatch
        return [self._report(dispatch, "running", now)]

    def again(self, dispatch_id: str) -> list:
        """The last report on the run ``dispatch_id``, sent again (a new
        commander commanded its task blind)."""
        last = self.last_reports.get(dispatch_id)
        return [] if last is None else [last]

    def _report(
        self, dispatch: messages.Dispatch, state: str, now: int
    ) -> messages.ActivityReport:
        """A report on ``dispatch``, echoing its id and term."""
        report = messages.ActivityReport(
            dispatch.task,
            state,  # type: ignore[arg-type]
            now,
            dispatch_id=dispatch.dispatch_id,
            term=dispatch.term,
        )
        self.last_reports[dispatch.dispatch_id] = report
        return report

    def step(self, now: int) -> list:
        """Advance the world to the start of unit ``now``; return reports."""
        out: list = []
        for task, (start, end, uses) in sorted(self.running.items()):
            for name, amount in uses.items():
                if name in self.levels and now - 1 >= start:
                    self.levels[name] -= amount
            fail_at = self.scenario.failures.get(task)
            if (
                fail_at is not None
                and task not in self.failed_once
                and now >= start + fail_at + 1
            ):
                self.failed_once.add(task)
                del self.running[task]
                self.executed.append(Activity(task, start, now))
                out.append(self._report(self.commands[task], "failed", now))
            elif now >= end:
                del self.running[task]
                self.executed.append(Activity(task, start, end))
                out.append(self._report(self.commands[task], "completed", now))
        if "battery" in self.levels and now > 0:
            self.levels["battery"] -= self.scenario.battery_drift
        if now > self.problem.start:
            # The sun and the heaters (the external rate of unit now - 1).
            for name in self.levels:
                self.levels[name] += self.problem.resources.external_profile(
                    name, now - 1, 1
                )[0]
        for name, top in self.ceilings.items():
            self.levels[name] = min(top, self.levels[name])  # full: lost
        if now % self.scenario.level_every == 0 and now > 0:
            for name in sorted(self.levels):
                out.append(
                    messages.ResourceLevel(
                        name, round(max(self.levels[name], 0.0), 6), now
                    )
                )
        return out


class World:
    """The non-scheduler side of the bus: clock, executor, goal source."""

    def __init__(
        self,
        session: zenoh.Session,
        topics: keys.Topics,
        executor: Executor,
        printer: Printer,
    ) -> None:
        self.session = session
        self.topics = topics
        self.executor = executor
        self.printer = printer
        self.inbox: queue.Queue[tuple[str, bytes]] = queue.Queue()
        self.plans: list[messages.PlanMessage] = []
        self.fence = Fence()
        self._sub = session.declare_subscriber(
            topics.key("scheduler/**"),
            zenoh.handlers.Callback(  # type: ignore[arg-type]
                lambda s: self.inbox.put(
                    (str(s.key_expr), s.payload.to_bytes())
                ),
                indirect=False,  # keep arrival order (see bus.inbox.direct)
            ),
        )

    def close(self) -> None:
        """Undeclare the subscriber."""
        self._sub.undeclare()

    def put(self, key: str, message: object) -> None:
        """Publish a message as JSON."""
        payload = (
            message if isinstance(message, bytes) else messages.encode(message)
        )
        self.session.put(key, payload, encoding=JSON)

    def status(self) -> messages.Status | None:
        """Query the scheduler's status (None if it does not answer)."""
        for reply in self.session.get(
            self.topics.key(keys.STATUS), timeout=5.0
        ):
            if reply.ok is not None:
                return msgspec.json.decode(
                    reply.ok.payload.to_bytes(), type=messages.Status
                )
        return None

    def settle(self, now: int, timeout: float = 120.0) -> None:
        """Wait until the scheduler has seen ``now`` and is not solving."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            status = self.status()
            if status is not None and status.now == now and not status.busy:
                self.drain(now)
                return
            self.drain(now)
            time.sleep(0.002)  # a solve is running: let it work
        raise TimeoutError(f"scheduler did not settle at t={now}")

    def advance(self, now: int, scenario: Scenario) -> None:
        """One unit of the world: tick, the executor's reports, goals due.

        Waits for the scheduler to settle after the tick and at the end.
        """
        topics = self.topics
        self.put(topics.key(keys.CLOCK), messages.Clock(now))
        self.settle(now)
        for report in self.executor.step(now):
            key = (
                topics.activity_report(report.task)
                if isinstance(report, messages.ActivityReport)
                else topics.resource_level(report.resource)
            )
            self.put(key, report)
        if now in scenario.goals:
            goal = scenario.goals[now]
            name = json.loads(goal).get("goal_id", "?")
            self.printer.line(f"goal      {name} sent")
            self.put(topics.key(keys.GOALS), goal)
        if now in scenario.forecasts:
            resource, fields = scenario.forecasts[now]
            self.printer.line(f"forecast  {resource} from t={fields['at']}")
            self.put(
                topics.resource_forecast(resource),
                {"resource": resource, **fields},
            )
        self.settle(now)

    def drain(self, now: int) -> None:
        """Handle what the scheduler published: dispatches, plans, status."""
        while True:
            try:
                key, payload = self.inbox.get_nowait()
            except queue.Empty:
                return
            kind = self.topics.schema_kind(key)
            if kind == "dispatch":
                dispatch = msgspec.json.decode(payload, type=messages.Dispatch)
                # The README's receiver rules: fenced by term, a run once
                # per dispatch_id (a resumed or new commander sends
                # standing ones again), a cancel answered each time it
                # comes, a blind command answered with the earlier run.
                fence = self.fence
                if fence.cancel(dispatch):
                    reports = self.executor.on_dispatch(dispatch, now)
                elif (earlier := fence.earlier_run(dispatch)) is not None:
                    reports = self.executor.again(earlier)
                elif fence.execute(dispatch):
                    reports = self.executor.on_dispatch(dispatch, now)
                else:
                    continue
                self.printer.dispatch(dispatch)
                for report in reports:
                    self.put(self.topics.activity_report(report.task), report)
            elif kind == "plan":
                plan = msgspec.json.decode(payload, type=messages.PlanMessage)
                self.fence.admit(plan)
                if any(p.plan_id == plan.plan_id for p in self.plans):
                    continue  # the same plan again (plan ids never reuse)
                self.plans.append(plan)
                self.printer.plan(plan)
            elif kind == "status":
                status = msgspec.json.decode(payload, type=messages.Status)
                self.fence.admit(status)
                self.printer.status(status)


class Printer:
    """The live, readable timeline on the terminal."""

    def __init__(self, stream: TextIO, quiet: bool = False) -> None:
        self.stream = stream
        self.quiet = quiet
        self.now = 0

    def line(self, text: str) -> None:
        """Print one timeline line."""
        if not self.quiet:
            print(f"t={self.now:>3}  {text}", file=self.stream, flush=True)

    def note(self, text: str) -> None:
        """Print a line outside the timeline (what the demo does next)."""
        if not self.quiet:
            print(text, file=self.stream, flush=True)

    def dispatch(self, d: messages.Dispatch) -> None:
        """A dispatch."""
        late = "  (late)" if d.late else ""
        if d.action == "cancel":
            self.line(f"cancel    {d.task:<20} [{d.start}, {d.end})")
            return
        self.line(f"dispatch  {d.task:<20} [{d.start}, {d.end}){late}")

    def plan(self, p: messages.PlanMessage) -> None:
        """A new plan."""
        objective = p.objective
        cost = (
            f"unscheduled {objective.unscheduled_cost}, "
            f"delay {objective.delay_cost}"
            if objective
            else "no objective"
        )
        self.line(
            f"PLAN {p.plan_id} ({p.trigger}, {p.status.value}, {cost}) "
            f"over [{p.horizon_start}, {p.horizon_end})"
        )
        for a in p.activities:
            mark = " continuing" if a.task in p.continuing else ""
            self.line(f"    {a.task:<20} [{a.start:>3}, {a.end:>3}){mark}")
        for name in p.unscheduled:
            self.line(f"    {name:<20} unscheduled")
        for r in p.removed:
            if r.rule != "finished":
                self.line(f"    removed {r.task} ({r.rule})")

    def status(self, s: messages.Status) -> None:
        """Status events worth a line."""
        if s.event in (
            "goal_accepted",
            "goal_rejected",
            "solve_failed",
            "drift",
            "input_rejected",
            "alarm",
        ):
            extra = s.goal_id or s.detail
            errors = "; ".join(f"{e.path}: {e.reason}" for e in s.errors)
            self.line(f"status    {s.event} {extra or ''} {errors}".rstrip())
        elif s.event == "activity":
            self.line(f"report    {s.detail}")
        elif s.event in ("resumed", "took_over"):
            self.line(
                f"status    {s.event} by {s.node_id}: plan {s.from_plan_id} "
                f"at t={s.at}, next plan id follows"
            )
        elif s.state == "standby":
            self.line(f"status    {s.node_id} stands by ({s.detail})")


@dataclass
class DemoResult:
    """What a demo run produced."""

    journal: Path
    plans: list[messages.PlanMessage]
    pictures: list[Path]
    executed: list[Activity]
    verified: bool | None


def run_demo(
    out_dir: Path,
    *,
    scenario: Scenario | None = None,
    spacecraft: str = "sat1",
    verify: bool = True,
    quiet: bool = False,
    pictures: bool = True,
    stream: TextIO = sys.stdout,
    time_unit: float = 0.0,
) -> DemoResult:
    """Run the paper scenario on an in-process bus.

    Parameters
    ----------
    out_dir
        Where the journal (``session.mcap``), the Gantt pictures and the
        final timeline go.
    scenario
        What the world does (default: the paper's).
    spacecraft
        Key prefix chunk.
    verify
        Replay the journal afterwards and report whether it reproduced
        every decision.
    quiet
        No live timeline.
    pictures
        Draw the Gantt pictures (needs matplotlib); the text timelines are
        written either way.
    stream
        Where the live timeline goes.
    time_unit
        Shortest wall time of one time unit, in seconds, so the timeline
        can be watched; the clock never outruns the scheduler anyway.
    """
    scenario = scenario or paper_scenario()
    out_dir.mkdir(parents=True, exist_ok=True)
    problem = decode_problem(scenario_file(scenario.problem))
    topics = keys.Topics(spacecraft)
    config = NodeConfig(
        spacecraft=spacecraft,
        clock="bus",
        time_limit=30.0,
        report_timeout=None,
        heartbeat=0,
        drift_absolute=scenario.drift_absolute,
    )
    journal_path = out_dir / "session.mcap"
    journal = Recorder(journal_path, schemas=schema_lookup(spacecraft))
    printer = Printer(stream, quiet)
    executor = Executor(problem, scenario)
    with open_peer_pair() as (bus_a, bus_b):
        node = SchedulerNode(bus_a, problem, config, journal=journal)
        node.start()
        world = World(bus_b, topics, executor, printer)
        try:
            wait_matching(bus_b, topics.key(keys.CLOCK))
            wait_matching(bus_b, topics.key(keys.GOALS))
            for now in range(scenario.until + 1):
                began = time.monotonic()
                printer.now = now
                world.advance(now, scenario)
                # Pacing only; every wait for the scheduler is on a query.
                time.sleep(max(time_unit - (time.monotonic() - began), 0.0))
        finally:
            world.close()
            node.close()
    plans = world.plans
    if pictures:
        printer.note(
            f"\ndrawing {len(plans)} plan pictures and the levels "
            "(a few seconds)..."
        )
    drawn = _draw(out_dir, journal_path, plans, executor, pictures=pictures)
    verified = None
    if verify:
        from ..journal.replay import verify as verify_journal

        printer.note(
            "replay --verify: running the journal's inputs through a fresh "
            "scheduler and comparing every decision..."
        )
        report = verify_journal(journal_path)
        verified = report.identical
        print(
            "\nreplay --verify: " + report.summary(), file=stream, flush=True
        )
    return DemoResult(journal_path, plans, drawn, executor.executed, verified)


def _draw(
    out_dir: Path,
    journal_path: Path,
    plans: list[messages.PlanMessage],
    executor: Executor,
    *,
    pictures: bool = True,
) -> list[Path]:
    """One text timeline and (with ``pictures``) one Gantt per plan.

    The problems come from the solve records of the journal. Returns the
    pictures drawn.
    """
    from ..journal.reader import iter_messages
    from ..view.session import moves_of, pins_of
    from ..view.timeline import timeline_text

    problems: dict[int, Problem] = {}
    for message in iter_messages(journal_path):
        if message.topic.endswith("/" + keys.SOLVES):
            record = msgspec.json.decode(
                message.payload, type=messages.SolveRecord
            )
            if record.plan_id is not None:
                problems[record.plan_id] = record.problem
    drawn: list[Path] = []
    before: tuple[Activity, ...] = ()
    for plan_message in plans:
        problem = problems.get(plan_message.plan_id)
        if problem is None:
            continue
        plan = Plan(
            status=plan_message.status,
            objective=plan_message.objective,
            activities=plan_message.activities,
            unscheduled=plan_message.unscheduled,
            why=plan_message.why,
        )
        text = timeline_text(
            problem,
            plan,
            moved=moves_of(plan_message),
            pinned=pins_of(problem, plan_message, before),
        )
        before = plan_message.activities
        (out_dir / f"plan-{plan_message.plan_id}.txt").write_text(text + "\n")
    if pictures:
        # The same pictures as `fsw-scheduler plot session.mcap`: what
        # ran before, removed tasks, binary lanes, measured levels.
        from ..view.session import attach_pictures, plot_session

        drawn = plot_session(journal_path, out_dir)
        # The journal carries its pictures (Foxglove lists attachments).
        copy = journal_path.with_suffix(".pictures.tmp")
        attach_pictures(journal_path, drawn, copy)
        copy.replace(journal_path)
    return drawn
