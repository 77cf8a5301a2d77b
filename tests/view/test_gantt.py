"""Tests of large Gantt charts: pages, both time axes, banded rows
(fsw_scheduler.view.gantt)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import pytest

from fsw_scheduler.analysis.greedy import greedy_plan
from fsw_scheduler.model.plan import Activity, Plan, SolveStatus
from fsw_scheduler.model.problem import Problem, Task, decode_problem
from fsw_scheduler.view.gantt import gantt
from fsw_scheduler.view.gantt_rows import row_ids
from fsw_scheduler.view.pages import ROWS_PER_PAGE

from ..factories import TABLE1_PLAN, bench_lib

if TYPE_CHECKING:
    from pathlib import Path

#: Highest page allowed, in pixels: 40 task rows, 3 binary lanes and 4
#: resource panels (the 150-task chart drawn in one figure was 6,601 px).
MAX_PAGE_PX = 2600


@dataclass
class Drawn:
    """A chart drawn: its problem and plan, the files and the figures."""

    problem: Problem
    plan: Plan
    paths: list[Path]
    figures: list[Any]


def _draw(
    problem: Problem, plan: Plan, path: Path, **kwargs: Any
) -> tuple[list[Path], list[Any]]:
    """``gantt`` with the figures it saves captured, to inspect them."""
    from matplotlib.figure import Figure

    figures: list[Any] = []
    save = Figure.savefig

    def capture(self: Any, *args: Any, **kw: Any) -> Any:
        figures.append(self)
        return save(self, *args, **kw)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Figure, "savefig", capture)
        paths = gantt(problem, plan, path, **kwargs)
    return paths, figures


@pytest.fixture(scope="module")
def large(tmp_path_factory: pytest.TempPathFactory) -> Drawn:
    """A generated 150-task problem (every resource kind) and the plan
    list scheduling gives it (deterministic, no solver), drawn."""
    doc = bench_lib("generator").generate_problem(150, "mixed", 336, 7)
    problem = decode_problem(json.dumps(doc))
    plan = greedy_plan(problem)
    assert plan is not None
    assert plan.activities and plan.unscheduled  # both kinds of rows
    out = tmp_path_factory.mktemp("large")
    paths, figures = _draw(problem, plan, out / "big.png", title="150 tasks")
    return Drawn(problem, plan, paths, figures)


def _task_axis(figure: Any) -> Any:
    return figure.axes[0]


def _rows_of(figure: Any) -> list[str]:
    return [t.get_text() for t in _task_axis(figure).get_yticklabels()]


def _top_axis(ax: Any) -> Any:
    (top,) = [
        child
        for child in ax.child_axes
        if type(child).__name__ == "SecondaryAxis"
    ]
    return top


def test_large_plan_is_written_as_pages_of_bounded_height(
    large: Drawn,
) -> None:
    """Tests that 150 rows give big-1.png .. big-4.png (no big.png), every
    page the same size and under the pixel bound, its PNG as high."""
    import matplotlib.image

    folder = large.paths[0].parent
    assert large.paths == [folder / f"big-{n}.png" for n in (1, 2, 3, 4)]
    assert sorted(p.name for p in folder.iterdir()) == [
        p.name for p in large.paths
    ]
    assert len(large.figures) == 4
    sizes = {tuple(f.get_size_inches() * f.dpi) for f in large.figures}
    assert len(sizes) == 1
    for path in large.paths:
        height, width, _ = matplotlib.image.imread(path).shape
        assert 1000 < height <= MAX_PAGE_PX
        assert width == 1210


def test_every_task_is_on_exactly_one_page(large: Drawn) -> None:
    """Tests that the pages' rows are all the tasks, each once, at most
    ROWS_PER_PAGE a page, and each page titled with its rows."""
    rows = [_rows_of(f) for f in large.figures]
    drawn = [name for page in rows for name in page]
    assert sorted(drawn) == sorted(t.id for t in large.problem.tasks)
    assert len(drawn) == len(set(drawn)) == 150
    assert all(len(page) <= ROWS_PER_PAGE for page in rows)
    first = 1
    for number, (figure, page) in enumerate(zip(large.figures, rows), 1):
        title = figure.get_suptitle()
        last = first + len(page) - 1
        assert title.startswith("150 tasks\nstatus feasible")
        assert title.endswith(
            f"rows {first}\u2013{last} of 150 (page {number} of 4)"
        )
        first = last + 1
    # Each bar is on its task's page only.
    for figure, page in zip(large.figures, rows, strict=True):
        spans = {
            t.get_text()
            for t in _task_axis(figure).texts
            if "\u2013" in t.get_text()
        }
        expected = {
            f"{a.start}\u2013{a.end}"
            for a in large.plan.activities
            if a.task in page
        }
        assert spans == expected


def test_rows_keep_their_time_order_across_pages(large: Drawn) -> None:
    """Tests that reading the pages one after another gives the rows in
    time order: by first start, the left-out tasks last."""
    drawn = [name for f in large.figures for name in _rows_of(f)]
    assert drawn == row_ids(large.problem, [], large.plan)
    start = {a.task: a.start for a in large.plan.activities}
    placed = [name for name in drawn if name in start]
    assert [start[name] for name in placed] == sorted(start.values())
    assert drawn[: len(placed)] == placed  # then only the left-out ones
    last_page = _rows_of(large.figures[-1])
    assert set(last_page) <= set(large.plan.unscheduled)


def test_every_page_has_the_time_axis_above_and_below(large: Drawn) -> None:
    """Tests that on every page the task rows have a top time axis with
    the bottom one's ticks, both labelled, the same range on all pages,
    and the page's last panel is labelled with the time."""
    ranges = set()
    for figure in large.figures:
        ax = _task_axis(figure)
        top = _top_axis(ax)
        assert top.xaxis.get_ticks_position() == "top"
        assert ax.xaxis.get_ticks_position() == "bottom"
        ticks = list(ax.get_xticks())
        assert len(ticks) >= 5
        assert list(top.get_xticks()) == ticks
        assert top.get_xlim() == ax.get_xlim()
        assert top.xaxis.get_tick_params()["labeltop"]
        assert ax.xaxis.get_tick_params()["labelbottom"]
        labels = [t.get_text() for t in ax.get_xticklabels()]
        assert labels == [t.get_text() for t in top.get_xticklabels()]
        assert "100" in labels
        bottom = figure.axes[-1]
        assert bottom is not ax  # resource panels follow the rows
        assert bottom.get_xlabel() == "time (units)"
        assert bottom.xaxis.get_tick_params()["labelbottom"]
        ranges.add(ax.get_xlim())
    assert ranges == {(0.0, 336.0)}


def test_rows_are_banded_with_a_guide_line(large: Drawn) -> None:
    """Tests every other row on a band and a guide line through each."""
    for figure in large.figures:
        ax = _task_axis(figure)
        num_rows = len(_rows_of(figure))
        guides = [
            line.get_ydata()[0]
            for line in ax.lines
            if list(line.get_xdata()) == [0, 1]
        ]
        assert guides == list(range(num_rows))
        bands = [
            p
            for p in ax.patches
            if p.get_zorder() == 0 and type(p).__name__ == "Rectangle"
        ]
        assert len(bands) == (num_rows + 1) // 2


def test_small_plan_keeps_one_file_and_its_look(
    tmp_path: Path, table1: Problem
) -> None:
    """Tests that a small chart is one file under the given name, untitled
    by rows, rows in time order, with the legend and a failed run hatched
    in red, and the top axis as well."""
    from fsw_scheduler.view.style import FAILED_COLOUR

    plan = Plan(
        SolveStatus.OPTIMAL,
        None,
        tuple(Activity(*a) for a in TABLE1_PLAN if a[1] >= 5),
    )
    history = [Activity(*a) for a in TABLE1_PLAN if a[1] < 5]
    broken = history[0]
    paths, (figure,) = _draw(
        table1.replace(start=5, horizon=45),
        plan,
        tmp_path / "t1.png",
        now=5,
        history=history,
        failed={(broken.task, broken.start)},
    )
    assert paths == [tmp_path / "t1.png"]
    assert [p.name for p in tmp_path.iterdir()] == ["t1.png"]
    assert "rows" not in figure.get_suptitle()
    ax = _task_axis(figure)
    ordered = sorted(TABLE1_PLAN, key=lambda a: (a[1], a[0]))
    assert _rows_of(figure) == [name for name, _, _ in ordered]
    assert _top_axis(ax).get_xticks().tolist() == ax.get_xticks().tolist()
    assert ax.get_legend() is not None
    hatched = [
        p
        for p in ax.patches
        if p.get_hatch() == "xx"
        and p.get_edgecolor()[:3] == _rgb(FAILED_COLOUR)
    ]
    assert len(hatched) == 1
    assert "failed" in [t.get_text() for t in ax.texts]


def _rgb(colour: str) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return to_rgb(colour)


def test_page_size_is_a_parameter(tmp_path: Path) -> None:
    """Tests ``rows_per_page``: 5 rows at 2 a page give 3 pages, the last
    one with the others' row pitch."""
    problem = Problem(
        horizon=10,
        tasks=tuple(Task(f"t{idx}", 1, 1, 1) for idx in range(5)),
    )
    plan = Plan(
        SolveStatus.OPTIMAL,
        None,
        tuple(Activity(f"t{idx}", idx, idx + 1) for idx in range(5)),
    )
    paths, figures = _draw(problem, plan, tmp_path / "p.png", rows_per_page=2)
    assert [p.name for p in paths] == ["p-1.png", "p-2.png", "p-3.png"]
    assert [_rows_of(f) for f in figures] == [
        ["t0", "t1"],
        ["t2", "t3"],
        ["t4"],
    ]
    assert {_task_axis(f).get_ylim() for f in figures} == {(1.6, -0.6)}


def _colour_pixels(path: Path, colour: str) -> int:
    """How many pixels of the PNG at ``path`` are exactly ``colour``."""
    import numpy as np
    from PIL import Image

    rgb = [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
    with Image.open(path) as image:
        pixels = np.asarray(image.convert("RGB"))
    return int((pixels == rgb).all(axis=2).sum())


def _paper_replans() -> dict[str, tuple[Problem, Plan, Any]]:
    """The Table 2 replan at t=15, free and with a 30-unit window."""
    import fsw_scheduler as fs

    from ..factories import DATA

    problem = (DATA / "paper_table1.json").read_text()
    plan = fs.solve(problem)
    goal = (DATA / "paper_table2_goal.json").read_bytes()
    return {
        "free": fs.replan(problem, plan, goal, 15),
        "window": fs.replan(problem, plan, goal, 15, commit_window=30),
    }


def test_a_moved_activity_has_its_old_place_ghosted(tmp_path: Path) -> None:
    """Tests on the Table 2 replan, which moves SetPositionY and
    DownlinkSat2Ground 5 units earlier, that the Gantt PNG draws each old
    place ghosted (the ghost's dashed outline colour is in the picture,
    one patch per moved task at its old start and length), and that the
    same chart without moves has no ghost at all."""
    from fsw_scheduler.model.plan import Moved
    from fsw_scheduler.view.style import GHOST_COLOUR

    problem, plan, diff = _paper_replans()["free"]
    moved = [Moved(m.task, m.old_start, m.new_start) for m in diff.moved]
    assert {m.task for m in moved} == {"SetPositionY", "DownlinkSat2Ground"}
    (with_moves,), figures = _draw(
        problem, plan, tmp_path / "moved.png", moved=moved, now=15
    )
    ghosts = {
        patch.get_gid(): (patch.get_x(), patch.get_width())
        for patch in figures[0].axes[0].patches
        if (patch.get_gid() or "").startswith("ghost:")
    }
    assert ghosts == {
        "ghost:SetPositionY": (38, 1),
        "ghost:DownlinkSat2Ground": (39, 10),
    }
    (plain,) = gantt(problem, plan, tmp_path / "plain.png", now=15)
    assert _colour_pixels(with_moves, GHOST_COLOUR) > 20
    assert _colour_pixels(plain, GHOST_COLOUR) == 0


def test_pinned_activities_are_marked(tmp_path: Path) -> None:
    """Tests on the Table 2 replan with a 30-unit commit window that the
    activities the window kept (SetPositionY and DownlinkSat2Ground
    stay at 38 and 39) are drawn with the pin outline, none is ghosted,
    and a chart without pins has no pin outline."""
    from fsw_scheduler.view.style import GHOST_COLOUR, PIN_COLOUR

    problem, plan, diff = _paper_replans()["window"]
    assert not diff.moved
    starts = plan.starts()
    pinned = [t for t in diff.kept if 15 <= starts[t] < 45]
    assert {"SetPositionY", "DownlinkSat2Ground"} <= set(pinned)
    (marked,), figures = _draw(
        problem, plan, tmp_path / "pinned.png", pinned=pinned, moved=[]
    )
    pins = {
        patch.get_gid()
        for patch in figures[0].axes[0].patches
        if (patch.get_gid() or "").startswith("pin:")
    }
    assert pins == {f"pin:{t}" for t in pinned}
    (plain,) = gantt(problem, plan, tmp_path / "plain.png")
    assert _colour_pixels(marked, PIN_COLOUR) > 50
    assert _colour_pixels(marked, GHOST_COLOUR) == 0
    assert _colour_pixels(plain, PIN_COLOUR) == 0
