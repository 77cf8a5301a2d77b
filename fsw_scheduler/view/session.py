"""Pictures of a recorded session: every plan; levels predicted vs measured.

``fsw-scheduler plot SESSION.mcap --out DIR`` reads a scheduler journal
(``run --record``, ``demo``) and draws

* ``plan-<id>.png`` for every plan: the Gantt of
  :func:`fsw_scheduler.view.gantt` with what had run before (from the
  activity reports), the tasks that replan removed (greyed, with the rule),
  the lanes of the binary resources, and the measured consumable levels
  while the plan was in force against its predicted profile (a plan of
  more than 40 task rows as pages ``plan-<id>-1.png``, ``plan-<id>-2.png``,
  ...);
* ``levels.png``: each consumable over the whole session, the profile each
  plan predicted (solid while it was in force, dotted after) against every
  measured sample, with a line at each replan.

Everything is read from the journal: plans, the solve records' problems,
activity reports, dispatches and level reports. Shell module: reads files,
imports matplotlib when drawing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec

from ..journal.reader import iter_messages
from ..model.levels import resource_profiles
from ..model.plan import Activity, Moved, Plan
from ..model.problem import Problem, Resources, Task
from ..wire import topics as keys
from ..wire.messages import (
    ActivityReport,
    Dispatch,
    NodeInfo,
    PlanMessage,
    ResourceLevel,
    SolveRecord,
)
from ..wire.profiles import Profiles
from .gantt import gantt
from .style import PALETTE, load_matplotlib

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ..journal.writer import PathLike

__all__ = [
    "Session",
    "attach_pictures",
    "moves_of",
    "pins_of",
    "plot_session",
    "read_session",
]


@dataclass
class Session:
    """What a journal says, in the shape the pictures need.

    Attributes
    ----------
    spacecraft
        From ``scheduler/config``.
    initial
        The initial problem.
    plans
        Every plan, in order.
    problems
        Plan id to the problem it solves (from the solve records; a plan
        adopted without a solve gets a problem with no task).
    executed
        Activities as they ran, from the activity reports (a run still
        open at the end of the journal ends at its dispatched end).
    measured
        Consumable name to its ``(at, level)`` reports, in order.
    failed
        The executions (task, start) that a ``failed`` report ended.
    tasks
        Every task definition seen (the latest one per id).
    """

    spacecraft: str = keys.DEFAULT_SPACECRAFT
    initial: Problem | None = None
    plans: list[PlanMessage] = field(default_factory=list)
    problems: dict[int, Problem] = field(default_factory=dict)
    executed: list[Activity] = field(default_factory=list)
    measured: dict[str, list[tuple[int, float]]] = field(default_factory=dict)
    tasks: dict[str, Task] = field(default_factory=dict)
    failed: set[tuple[str, int]] = field(default_factory=set)


def read_session(path: PathLike) -> Session:
    """Read a scheduler journal into a :class:`Session`.

    Raises
    ------
    ValueError
        If the file has no ``scheduler/config`` (not a scheduler journal).
    """
    messages = list(iter_messages(path))
    session = Session()
    info = next(
        (m for m in messages if m.topic.endswith("/" + keys.NODE_INFO)), None
    )
    if info is None:
        raise ValueError(
            f"{path}: no scheduler/config message: not a scheduler journal"
        )
    node = msgspec.json.decode(info.payload, type=NodeInfo)
    session.spacecraft = node.spacecraft
    session.initial = node.problem
    topics = keys.Topics(node.spacecraft)
    running: dict[str, int] = {}
    planned_end: dict[str, int] = {}
    profiles: dict[int, Profiles] = {}
    stand_ins: list[int] = []
    last: Problem | None = node.problem
    for message in messages:
        kind = topics.schema_kind(message.topic)
        try:
            if kind == "solve_record":
                record = msgspec.json.decode(message.payload, type=SolveRecord)
                if record.plan_id is not None:
                    session.problems[record.plan_id] = record.problem
                session.tasks.update((t.id, t) for t in record.problem.tasks)
            elif kind == "plan":
                plan = msgspec.json.decode(message.payload, type=PlanMessage)
                if plan.plan_id not in session.problems:
                    session.problems[plan.plan_id] = _stand_in(
                        last,
                        session.plans[-1] if session.plans else None,
                        plan,
                    )
                    stand_ins.append(plan.plan_id)
                session.plans.append(plan)
                last = session.problems[plan.plan_id]
            elif kind == "profiles":
                profile = msgspec.json.decode(message.payload, type=Profiles)
                profiles[profile.plan_id] = profile
            elif kind == "dispatch":
                dispatch = msgspec.json.decode(message.payload, type=Dispatch)
                planned_end[dispatch.task] = dispatch.end
            elif kind == "activity_report":
                report = msgspec.json.decode(
                    message.payload, type=ActivityReport
                )
                if report.state == "running":
                    running[report.task] = report.at
                elif report.task in running:
                    start = running.pop(report.task)
                    session.executed.append(
                        Activity(report.task, start, max(report.at, start))
                    )
                    if report.state == "failed":
                        session.failed.add((report.task, start))
            elif kind == "resource_level":
                level = msgspec.json.decode(
                    message.payload, type=ResourceLevel
                )
                session.measured.setdefault(level.resource, []).append(
                    (level.at, level.level)
                )
        except (msgspec.DecodeError, msgspec.ValidationError):
            continue  # rejected inputs are in the journal too
    # A plan adopted without a solve: the node's published profile knows
    # its starting levels exactly (older journals keep the estimate).
    for plan_id in stand_ins:
        known = profiles.get(plan_id)
        if known is None:
            continue
        problem = session.problems[plan_id]
        consumable = {
            name: known.levels[name][0]
            for name in problem.resources.consumable
            if known.levels.get(name)
        }
        session.problems[plan_id] = problem.replace(
            resources=problem.resources.with_levels(consumable)
        )
    for task, start in running.items():
        end = planned_end.get(task, start + 1)
        session.executed.append(Activity(task, start, max(end, start + 1)))
    session.executed.sort(key=lambda a: (a.start, a.task))
    return session


def _stand_in(
    last: Problem | None, before: PlanMessage | None, plan: PlanMessage
) -> Problem:
    """A task-free problem over a plan's horizon (nothing left to plan).

    Its starting levels are what the plan before predicted for the start
    of this one (replaced by the published profile when there is one).
    """
    resources = last.resources if last is not None else Resources()
    if last is not None and before is not None:
        at = plan.horizon_start - last.start
        consumable = {}
        for name in resources.consumable:
            levels = _levels_at_starts(last, before, name)
            consumable[name] = levels[min(max(at, 0), len(levels) - 1)]
        resources = resources.with_levels(consumable)
    return Problem(
        horizon=max(plan.horizon_end - plan.horizon_start, 1),
        start=plan.horizon_start,
        tasks=(),
        resources=resources,
    )


def moves_of(message: PlanMessage) -> tuple[Moved, ...]:
    """What the replan that made ``message`` moved (none when its node
    did not report moves)."""
    moved = message.moved
    return () if isinstance(moved, msgspec.UnsetType) else tuple(moved)


def pins_of(
    problem: Problem,
    message: PlanMessage,
    previous: Sequence[Activity],
    initial: Problem | None = None,
) -> frozenset[str]:
    """The activities the replan's commit window pinned.

    A pin is a ``fixed_start`` the solved ``problem`` (from the solve
    record) gave a task that was planned there before and is not running
    on (``continuing``): only on a node that reports moves (a window or a
    stability term), and never a start its own definition (the initial
    problem) fixed.
    """
    if isinstance(message.moved, msgspec.UnsetType):
        return frozenset()
    before = {a.task: a.start for a in previous}
    own = {t.id: t.fixed_start for t in (initial.tasks if initial else ())}
    starts = {a.task: a.start for a in message.activities}
    return frozenset(
        t.id
        for t in problem.tasks
        if t.fixed_start is not None
        and t.id not in message.continuing
        and before.get(t.id) == t.fixed_start == starts.get(t.id)
        and own.get(t.id) != t.fixed_start
    )


def _as_plan(message: PlanMessage) -> Plan:
    return Plan(
        status=message.status,
        objective=message.objective,
        activities=message.activities,
        unscheduled=message.unscheduled,
        why=message.why,
    )


def plot_session(path: PathLike, out_dir: PathLike) -> list[Path]:
    """Draw every plan of a journal and the levels, predicted vs measured.

    Parameters
    ----------
    path
        A scheduler journal.
    out_dir
        Folder for the pictures (created if missing).

    Returns
    -------
    list of Path
        ``plan-<id>.png`` per plan (its pages ``plan-<id>-<n>.png`` when
        it has more rows than one page holds), then ``levels.png`` when
        the problem has consumables.
    """
    session = read_session(path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    drawn: list[Path] = []
    previous: tuple[Activity, ...] = ()
    for idx, plan in enumerate(session.plans):
        problem = session.problems[plan.plan_id]
        until = (
            session.plans[idx + 1].issued_at
            if idx + 1 < len(session.plans)
            else None
        )
        now = plan.issued_at
        history = [a for a in session.executed if a.start < now]
        removed = {
            r.task: r.rule for r in plan.removed if r.rule != "finished"
        }
        measured = {
            name: [
                (at, level)
                for at, level in samples
                if until is None or at <= until
            ]
            for name, samples in session.measured.items()
            if name in problem.resources.consumable
        }
        past = [
            task
            for name, task in session.tasks.items()
            if name not in {t.id for t in problem.tasks}
        ]
        target = out / f"plan-{plan.plan_id}.png"
        in_force = (
            f"in force t={now}..{until}"
            if until is not None
            else f"from t={now}"
        )
        pages = gantt(
            problem,
            _as_plan(plan),
            target,
            title=f"plan {plan.plan_id} ({plan.trigger or 'initial'}), "
            f"{in_force}",
            now=now if (history or now > problem.start) else None,
            history=history or None,
            removed=removed or None,
            previous=previous,
            measured=measured,
            past_tasks=past,
            failed=session.failed,
            moved=moves_of(plan),
            pinned=pins_of(problem, plan, previous, session.initial),
        )
        drawn += pages
        previous = plan.activities
    if session.initial is not None and session.initial.resources.consumable:
        target = out / "levels.png"
        draw_levels(session, target)
        drawn.append(target)
    return drawn


def draw_levels(session: Session, path: Path) -> Path:
    """Each consumable over the session: every plan's prediction, measured.

    A plan's profile is solid from its start until the next plan replaced
    it, and dotted afterwards (what it would have been); measured levels
    are dots; each replan is a thin vertical line with the plan id.
    """
    Figure, FigureCanvasAgg, _Patch = load_matplotlib()
    assert session.initial is not None
    names = list(session.initial.resources.consumable)
    fig = Figure(figsize=(11, 0.6 + 2.6 * len(names)), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    plans = session.plans
    # Up to where things happened, plus a quarter horizon of the last
    # plan's prediction (not its whole horizon, which hides the session).
    last_seen = max(
        [p.issued_at for p in plans]
        + [at for s in session.measured.values() for at, _ in s]
        + [a.end for a in session.executed]
        + [1]
    )
    x_hi = last_seen + max(session.initial.horizon // 4, 1)
    for ax, name in zip(axes, names, strict=True):
        for idx, plan in enumerate(plans):
            problem = session.problems[plan.plan_id]
            if name not in problem.resources.consumable:
                continue
            levels = _levels_at_starts(problem, plan, name)
            times = list(range(problem.start, problem.end + 1))
            until = plans[idx + 1].issued_at if idx + 1 < len(plans) else None
            colour = PALETTE[idx % 2]
            flown = [
                (t, v)
                for t, v in zip(times, levels, strict=True)
                if until is None or t <= until
            ]
            after = [
                (t, v)
                for t, v in zip(times, levels, strict=True)
                if until is not None and t >= until
            ]
            if flown:
                ax.step(
                    *zip(*flown, strict=True),
                    where="post",
                    color=colour,
                    linewidth=1.6,
                    label="predicted (plan in force)" if idx == 0 else None,
                )
            if after:
                ax.step(
                    *zip(*after, strict=True),
                    where="post",
                    color=colour,
                    linewidth=0.8,
                    linestyle=":",
                    alpha=0.4,
                    label="predicted, after the plan was replaced"
                    if idx == 0
                    else None,
                )
            if idx:
                ax.axvline(
                    plan.issued_at, color="#bbbbbb", linewidth=0.7, zorder=0
                )
                ax.annotate(
                    f"{plan.plan_id}",
                    xy=(plan.issued_at, 1),
                    xycoords=("data", "axes fraction"),
                    xytext=(2, -2),
                    textcoords="offset points",
                    fontsize=7,
                    color="#777777",
                    va="top",
                )
        samples = session.measured.get(name, [])
        if samples:
            ax.plot(
                *zip(*samples, strict=True),
                "o",
                color="#D55E00",
                markersize=5,
                markeredgecolor="white",
                markeredgewidth=0.6,
                zorder=5,
                label="measured",
            )
        ax.axhline(0, color="#333333", linewidth=0.8)
        ceiling = session.initial.resources.ceiling(name)
        if ceiling is not None:
            ax.axhline(
                ceiling,
                color="#333333",
                linewidth=0.8,
                linestyle="--",
                label=f"capacity {ceiling:g}",
            )
        ax.set_ylabel(f"{name} level", fontsize=9)
        ax.grid(axis="both", color="#eeeeee", linewidth=0.7)
        ax.set_axisbelow(True)
        for side in ("top", "right"):
            ax.spines[side].set_visible(False)
        ax.set_xlim(0, x_hi)
        if ax is axes[0]:
            ax.legend(
                loc="upper left",
                bbox_to_anchor=(1.01, 1.0),
                fontsize=8,
                frameon=False,
                title="colours alternate\nfrom plan to plan",
                title_fontsize=7,
            )
    axes[-1].set_xlabel("time (units); thin lines: replans, with the plan id")
    fig.suptitle(
        f"{session.spacecraft}: consumables, predicted by each plan "
        "against measured",
        fontsize=12,
        x=0.02,
        ha="left",
    )
    fig.savefig(path, format="png", dpi=110)
    return path


def _levels_at_starts(
    problem: Problem, plan: PlanMessage, name: str
) -> list[float]:
    """Level at the start of each unit ``problem.start .. problem.end``."""
    ends = resource_profiles(problem, _as_plan(plan))[name]
    return [float(problem.resources.initial(name)), *ends]


def attach_pictures(
    journal: PathLike, pictures: Sequence[Path], dst: PathLike
) -> Path:
    """A copy of ``journal`` with ``pictures`` attached (``image/png``).

    Parameters
    ----------
    journal
        The recording (left unchanged).
    pictures
        PNG files, attached under their file names.
    dst
        The copy to write (distinct from ``journal``).

    Returns
    -------
    Path
        ``dst``.
    """
    from ..journal.recover import recover

    recover(
        journal,
        dst,
        attachments=[(p.name, "image/png", p.read_bytes()) for p in pictures],
    )
    return Path(dst)
