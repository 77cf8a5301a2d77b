"""Tests of the plan views (fsw_scheduler.view: timeline and Gantt)."""

from __future__ import annotations

import subprocess
import sys
from typing import TYPE_CHECKING

import pytest

from fsw_scheduler.model.levels import resource_profiles
from fsw_scheduler.model.plan import (
    Activity,
    Blocker,
    Objective,
    Plan,
    SolveStatus,
)
from fsw_scheduler.model.problem import Problem, Resources, Task
from fsw_scheduler.view.gantt import gantt
from fsw_scheduler.view.timeline import timeline_text

from ..factories import ROOT, TABLE1_PLAN

if TYPE_CHECKING:
    from pathlib import Path

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _plan(
    activities: tuple[tuple[str, int, int], ...],
    *,
    objective: Objective | None = None,
    unscheduled: tuple[str, ...] = (),
    why: tuple[Blocker, ...] = (),
    status: SolveStatus = SolveStatus.OPTIMAL,
) -> Plan:
    return Plan(
        status=status,
        objective=objective,
        activities=tuple(Activity(*a) for a in activities),
        unscheduled=unscheduled,
        why=why,
    )


@pytest.fixture(scope="session")
def table1_plan() -> Plan:
    """The optimal plan of the paper's Table 1 problem."""
    return _plan(TABLE1_PLAN, objective=Objective(0, 359, 359))


@pytest.fixture(scope="session")
def small() -> Problem:
    """Two tasks sharing power; one drains and one charges a battery."""
    return Problem(
        horizon=8,
        start=2,
        tasks=(
            Task("drain", 3, 1, 1, uses={"cam": 1, "power": 4, "bat": 2}),
            Task("charge", 2, 1, 1, uses={"power": 3, "bat": -1.5}),
            Task("spare", 1, 1, 2, uses={"power": 1}),
        ),
        resources=Resources(
            binary=("cam",), multiple={"power": 6}, consumable={"bat": 5}
        ),
    )


def _check_png(path: Path) -> None:
    import matplotlib.image

    data = path.read_bytes()
    assert data.startswith(PNG_SIGNATURE)
    image = matplotlib.image.imread(path)
    assert image.shape[0] > 100
    assert image.shape[1] > 100


# --------------------------------------------------------------------------
# resource_profiles


def test_profiles_multiple_sum(small: Problem) -> None:
    """Tests that overlapping activities add up on a multiple resource."""
    plan = _plan((("drain", 2, 5), ("charge", 4, 6), ("spare", 9, 10)))
    profiles = resource_profiles(small, plan)
    assert list(profiles) == ["power", "bat"]
    assert profiles["power"] == [4, 4, 7, 3, 0, 0, 0, 1]


def test_profiles_consumable_with_generation(small: Problem) -> None:
    """Tests end-of-unit consumable levels with a generating task."""
    plan = _plan((("drain", 2, 5), ("charge", 4, 6)))
    levels = resource_profiles(small, plan)["bat"]
    # unit 2: 5-2; 3: -2; 4: -2+1.5; 5: +1.5; then flat.
    assert levels == [3, 1, 0.5, 2, 2, 2, 2, 2]


def test_profiles_negative_level_kept(small: Problem) -> None:
    """Tests that a level below zero is reported as is, not clamped."""
    problem = small.replace(
        resources=Resources(
            binary=("cam",), multiple={"power": 6}, consumable={"bat": 3}
        )
    )
    levels = resource_profiles(problem, _plan((("drain", 3, 6),)))["bat"]
    assert levels == [3, 1, -1, -3, -3, -3, -3, -3]


def test_profiles_empty_plan(small: Problem) -> None:
    """Tests that a plan without activities gives flat profiles."""
    plan = _plan((), status=SolveStatus.UNKNOWN)
    profiles = resource_profiles(small, plan)
    assert profiles == {"power": [0.0] * 8, "bat": [5.0] * 8}


def test_profiles_reject_unknown_task(small: Problem) -> None:
    """Tests that an activity for a task absent from the problem fails."""
    with pytest.raises(ValueError, match="ghost"):
        resource_profiles(small, _plan((("ghost", 2, 3),)))


def test_profiles_table1(table1: Problem, table1_plan: Plan) -> None:
    """Tests the Table 1 plan's power peak and battery low point."""
    profiles = resource_profiles(table1, table1_plan)
    assert max(profiles["power"]) == 40
    assert min(profiles["battery"]) == 2
    assert profiles["battery"][6] == 2
    assert profiles["battery"][-1] == 10
    assert profiles["propellant"][-1] == 92


# --------------------------------------------------------------------------
# timeline_text


def test_timeline_table1(table1: Problem, table1_plan: Plan) -> None:
    """Tests the text timeline of the paper's Table 1 plan."""
    text = timeline_text(table1, table1_plan)
    lines = text.splitlines()
    assert lines[0] == (
        "Plan: status optimal, unscheduled cost 0, delay cost 359, total 359"
    )
    rows = [line for line in lines if line.endswith("|") and "#" in line]
    order = [row.split()[0] for row in rows]
    expected = sorted(TABLE1_PLAN, key=lambda a: (a[1], a[0]))
    assert order == [name for name, _, _ in expected]
    spans = [row.split()[1] for row in rows]
    assert spans == [f"{s}-{e}" for _, s, e in expected]
    # Horizon 50 fits the default width: one character per time unit.
    charge = next(r for r in rows if r.startswith("BatteryCharge"))
    bar = charge[charge.index("|") + 1 : -1]
    assert bar == "." * 7 + "#" * 10 + "." * 33
    assert all(len(line) <= 80 for line in lines)
    assert "unscheduled:" not in text
    assert "battery     min 2 at end of t=6 (initial 20, final 10)" in text
    assert "propellant  min 92 at end of t=38" in text
    assert "power       peak 40/60 at t=0" in text
    assert "\x1b" not in text
    assert text == timeline_text(table1, table1_plan)


def test_timeline_width_scales_bar(table1: Problem, table1_plan: Plan) -> None:
    """Tests that a narrow width shrinks bars without losing tasks."""
    text = timeline_text(table1, table1_plan, width=50)
    rows = [line for line in text.splitlines() if line.endswith("|")]
    assert len(rows) == 10  # ruler + nine tasks
    assert all(len(row) <= 50 for row in rows)
    for row in rows[1:]:
        assert row.count("#") >= 1


def test_timeline_unscheduled_reasons(table1: Problem) -> None:
    """Tests that unscheduled tasks are listed with their reasons."""
    kept = tuple(a for a in TABLE1_PLAN if a[0] != "DownlinkSat2Ground")
    plan = _plan(
        kept,
        objective=Objective(3, 300, 3 * 1351 + 300),
        unscheduled=("DownlinkSat2Ground",),
        why=(Blocker("DownlinkSat2Ground", "cost", "not worth it"),),
        status=SolveStatus.FEASIBLE,
    )
    text = timeline_text(table1, plan)
    assert "8 scheduled, 1 unscheduled" in text
    assert (
        "unscheduled:\n  DownlinkSat2Ground (cost 3): cost: not worth it\n"
        in text
    )


def test_timeline_infeasible_blockers(small: Problem) -> None:
    """Tests that blocked mandatory tasks appear even if not unscheduled."""
    plan = _plan(
        (),
        status=SolveStatus.INFEASIBLE,
        why=(Blocker("drain", "window", "no start fits"),),
    )
    text = timeline_text(small, plan)
    assert text.startswith("Plan: status infeasible\n")
    assert "  drain (cost 1): window: no start fits" in text


def test_timeline_flags_violations(small: Problem) -> None:
    """Tests that over-capacity and below-zero levels are flagged."""
    problem = small.replace(
        resources=Resources(
            binary=("cam",), multiple={"power": 5}, consumable={"bat": 2}
        )
    )
    plan = _plan((("drain", 2, 5), ("charge", 3, 5)))
    text = timeline_text(problem, plan)
    assert "power  peak 7/5 at t=3 OVER CAPACITY" in text
    assert "bat    min -1 at end of t=4 BELOW ZERO" in text
    coloured = timeline_text(problem, plan, color=True)
    assert "\x1b[31m" in coloured


def test_timeline_no_resources() -> None:
    """Tests that a problem without resources has no resource section."""
    problem = Problem(horizon=4, tasks=(Task("a", 2, 1, 1),))
    text = timeline_text(problem, _plan((("a", 1, 3),)))
    assert "resources:" not in text
    # A short horizon gets a whole number of characters per time unit.
    bar = "." * 16 + "#" * 32 + "." * 16
    assert f"\na     1-3   |{bar}|\n" in text


# --------------------------------------------------------------------------
# gantt


def test_gantt_table1_png(
    tmp_path: Path, table1: Problem, table1_plan: Plan
) -> None:
    """Tests that the Table 1 plan is drawn as a readable PNG."""
    out = gantt(table1, table1_plan, tmp_path / "t1.png", title="Table 1")
    assert out == [tmp_path / "t1.png"]
    _check_png(*out)


def test_gantt_replan_with_history(tmp_path: Path, table1: Problem) -> None:
    """Tests a replan picture with a now line, history and left-out tasks."""
    problem = table1.replace(start=10, horizon=40)
    plan = _plan(
        (("SetPositionZ", 17, 18), ("AcquisitionHF", 18, 38)),
        objective=Objective(6, 100, 6 * 1 + 100),
        unscheduled=("DownlinkSat2Ground", "SetPositionY"),
        why=(Blocker("DownlinkSat2Ground", "window", "closes at 45"),),
        status=SolveStatus.FEASIBLE,
    )
    history = [
        Activity("SetHFOption", 0, 1),
        Activity("DownlinkSat2Sat", 1, 6),
        Activity("BatteryCharge", 7, 17),  # still running at now
        Activity("OldGoalTask", 2, 4),  # not in the new problem
    ]
    out = gantt(
        problem, plan, str(tmp_path / "replan.png"), now=10, history=history
    )
    _check_png(*out)


def test_gantt_unscheduled_and_violation(
    tmp_path: Path, small: Problem
) -> None:
    """Tests a picture with an unscheduled task and a level below zero."""
    plan = _plan(
        (("drain", 2, 5), ("charge", 4, 6)),
        unscheduled=("spare",),
        status=SolveStatus.FEASIBLE,
    )
    problem = small.replace(
        resources=Resources(
            binary=("cam",), multiple={"power": 5}, consumable={"bat": 1}
        )
    )
    _check_png(*gantt(problem, plan, tmp_path / "v.png", now=4))


def test_gantt_no_resources(tmp_path: Path) -> None:
    """Tests that a problem without resources has only the task panel."""
    problem = Problem(
        horizon=5, tasks=(Task("a", 2, 1, 1), Task("b", 1, 1, 1))
    )
    plan = _plan((("a", 0, 2),), unscheduled=("b",))
    _check_png(*gantt(problem, plan, tmp_path / "none.png"))


def test_gantt_without_plan(tmp_path: Path, small: Problem) -> None:
    """Tests that a plan with no activities and no objective still draws."""
    plan = _plan((), status=SolveStatus.UNKNOWN)
    _check_png(*gantt(small, plan, tmp_path / "empty.png"))


def test_gantt_missing_matplotlib(
    tmp_path: Path, small: Problem, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that a missing matplotlib gives an ImportError with a hint."""
    for name in list(sys.modules):
        if name == "matplotlib" or name.startswith("matplotlib."):
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ImportError, match=r"fsw-scheduler\[plot\]"):
        gantt(small, _plan(()), tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


def test_import_does_not_load_matplotlib() -> None:
    """Tests that importing fsw_scheduler.view.gantt leaves matplotlib
    unloaded."""
    code = (
        "import sys, fsw_scheduler.view.gantt; "
        "print('matplotlib' in sys.modules)"
    )
    result = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    )
    assert result.stdout.strip() == "False"


def _drawn_figure(monkeypatch: pytest.MonkeyPatch) -> list:
    """Capture the figures gantt saves, to read their texts back."""
    from matplotlib.figure import Figure

    figures: list = []
    save = Figure.savefig

    def capture(self, *args, **kwargs):
        figures.append(self)
        return save(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", capture)
    return figures


def _texts(figure) -> list[str]:
    found = []
    for ax in figure.axes:
        found += [t.get_text() for t in ax.texts]
        found += [t.get_text() for t in ax.get_yticklabels()]
        legend = ax.get_legend()
        if legend is not None:
            found += [t.get_text() for t in legend.get_texts()]
    return found


def test_gantt_binary_lanes_removed_and_measured(
    tmp_path: Path,
    table1: Problem,
    table1_plan: Plan,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Tests the binary lanes, greyed removed tasks and measured dots."""
    figures = _drawn_figure(monkeypatch)
    problem = table1.replace(start=15, horizon=50)
    plan = _plan((("AcquisitionHF", 18, 38), ("SetPositionZ", 17, 18)))
    previous = [Activity("Gone", 20, 30), Activity("SetPositionZ", 17, 18)]
    gantt(
        problem,
        plan,
        tmp_path / "lanes.png",
        now=15,
        history=[Activity("Done", 3, 8)],
        removed={"Gone": "obsolete", "SetPositionZ": "tight_cascade"},
        previous=previous,
        measured={"battery": [(5, 10.0), (15, 80.0)]},
        past_tasks=[Task("Done", 5, 1, 1, uses={"camera": 1})],
    )
    (figure,) = figures
    texts = _texts(figure)
    assert "who holds each binary resource" in texts
    assert {"camera", "antenna", "reaction_wheel", "position"} <= set(texts)
    assert "AcquisitionHF" in texts  # named in its camera lane
    assert " removed: obsolete " in texts
    assert "(the previous SetPositionZ: removed, tight_cascade)" in texts
    assert "measured" in texts and "predicted" in texts
    task_axis = figure.axes[0]
    labels = {t.get_text(): t for t in task_axis.get_yticklabels()}
    assert labels["Gone"].get_style() == "italic"
    assert labels["SetPositionZ"].get_style() == "normal"
    # Dots at the measured times, on the battery panel.
    battery = next(
        ax
        for ax in figure.axes
        if any("battery" in t.get_text() for t in ax.texts)
    )
    dots = [line for line in battery.lines if line.get_label() == "measured"]
    assert list(dots[0].get_xdata()) == [5, 15]
    _check_png(tmp_path / "lanes.png")


def test_gantt_without_binary_resources_has_no_lanes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests that the lanes panel only appears with binary resources."""
    figures = _drawn_figure(monkeypatch)
    problem = Problem(horizon=5, tasks=(Task("a", 2, 1, 1),))
    gantt(problem, _plan((("a", 0, 2),)), tmp_path / "plain.png")
    assert "who holds each binary resource" not in _texts(figures[0])


def test_gantt_rows_follow_time_not_problem_order() -> None:
    """Tests that the rows go by first start (what ran first on top), the
    left-out tasks last in problem order."""
    from fsw_scheduler.view.gantt_rows import row_ids

    problem = Problem(
        horizon=10,
        tasks=tuple(
            Task(name, 1, 1, 1) for name in ("late", "out", "early", "ran")
        ),
    )
    plan = Plan(
        SolveStatus.OPTIMAL,
        None,
        (Activity("late", 6, 7), Activity("early", 2, 3)),
        ("out",),
    )
    history = [Activity("ran", 0, 1), Activity("gone", 1, 2)]
    assert row_ids(problem, history, plan) == [
        "ran",
        "gone",
        "early",
        "late",
        "out",
    ]


# --------------------------------------------------------------------------
# The mission model in the views


@pytest.fixture(scope="session")
def orbit() -> tuple[Problem, Plan]:
    """A pass window, power steps, sunlight charge and a group, solved."""
    import json

    from fsw_scheduler.model.problem import decode_problem
    from fsw_scheduler.solving.solve import solve

    problem = decode_problem(
        json.dumps(
            {
                "horizon": 20,
                "resources": {
                    "binary": {"antenna": {"available": [[6, 12]]}},
                    "multiple": {"power": {"steps": [[0, 2], [10, 4]]}},
                    "consumable": {
                        "battery": {
                            "initial": 2,
                            "max": 6,
                            "external": [[0, 1], [8, 0], [14, -0.5]],
                        }
                    },
                },
                "tasks": [
                    {
                        "id": "Down",
                        "length": 3,
                        "delay_cost": 1,
                        "schedule_cost": 2,
                        "uses": {"antenna": 1, "power": 1},
                    },
                    {
                        "id": "HF",
                        "length": 4,
                        "delay_cost": 2,
                        "uses": {"power": 2, "battery": 1},
                    },
                    {
                        "id": "LF",
                        "length": 2,
                        "delay_cost": 1,
                        "uses": {"power": 1, "battery": 1},
                    },
                ],
                "alternatives": [
                    {
                        "id": "img",
                        "schedule_cost": 3,
                        "options": [["HF"], ["LF"]],
                    }
                ],
            }
        )
    )
    return problem, solve(problem, explain=True)


def test_timeline_names_the_chosen_option(orbit: tuple) -> None:
    """Tests that the text timeline names each group's option and says
    why the other was not chosen, and calls capacity steps so."""
    problem, plan = orbit
    text = timeline_text(problem, plan)
    # Either option costs 6 (the downlink waits for the antenna either
    # way): the one chosen is named, the other said not chosen.
    names = ("HF", "LF")
    chosen = plan.chosen["img"]
    assert (
        f"alternatives:\n  img: option {chosen} ({names[chosen]})\n"
        f"    option {1 - chosen} ({names[1 - chosen]}) not"
    ) in text
    assert "a tie" in text
    assert "(in steps)" in text
    assert "unscheduled:" not in text


def test_gantt_draws_windows_steps_and_external_charge(
    tmp_path: Path, orbit: tuple, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Tests the pictures of changing resources: the antenna lane hatched
    outside its window, the power capacity as steps, the battery panel
    banded where the sun charges (gold) and the heater drains (blue),
    with the totals in its label."""
    from matplotlib.colors import to_hex

    from fsw_scheduler.view.style import (
        CHARGE_COLOUR,
        CLOSED_COLOUR,
        DRAIN_COLOUR,
    )

    figures = _drawn_figure(monkeypatch)
    problem, plan = orbit
    gantt(problem, plan, tmp_path / "orbit.png")
    (figure,) = figures
    texts = _texts(figure)
    lanes = next(
        ax
        for ax in figure.axes
        if "who holds each binary resource" in [t.get_text() for t in ax.texts]
    )
    closed = [
        c
        for c in lanes.collections
        if to_hex(c.get_facecolor()[0]) == CLOSED_COLOUR
    ]
    (bars,) = closed
    spans = sorted(
        (round(path.get_extents().x0), round(path.get_extents().x1))
        for path in bars.get_paths()
    )
    assert spans == [(0, 6), (12, 20)]
    assert any("power  (capacity 2..4 in steps" in t for t in texts)
    battery = next(
        ax
        for ax in figure.axes
        if any(t.get_text().startswith("battery") for t in ax.texts)
    )
    colours = {to_hex(p.get_facecolor()) for p in battery.patches}
    assert {CHARGE_COLOUR, DRAIN_COLOUR} <= colours
    assert any("external +8 -3" in t for t in texts)
    _check_png(tmp_path / "orbit.png")


def test_a_gantt_of_several_pages_says_each_page(
    table1: Problem,
    table1_plan: Plan,
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Tests that drawing a plan over several pages logs a line per page
    (a long plan took tens of seconds there without a word)."""
    caplog.set_level("INFO", logger="fsw_scheduler.view")
    written = gantt(
        table1, table1_plan, tmp_path / "plan.png", rows_per_page=4
    )
    lines = [r.getMessage() for r in caplog.records]
    assert len(written) > 1
    assert len([m for m in lines if m.startswith("drawing ")]) == len(written)
