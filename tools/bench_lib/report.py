"""Tables, CSV and box plots of benchmark runs.

Tables give, per solver and group, the median / p90 / mean of the end-to-end
wall time and the medians of its three parts (model build, solver overhead,
solve), the number of time-outs and of check failures, and the paper's
average beside it (its Table 3 and the text about Figure 3). The paper
reports averages on another machine; compare orders of magnitude.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import statistics
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

from .generator import CAMPAIGN_SIZES, CLASSES

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence
    from pathlib import Path

    from .runner import Outcome, Run

PAPER_PROPOSED_BY_SIZE: dict[int, float] = {5: 0.2, 10: 0.6, 15: 0.9}
PAPER_PROPOSED_BY_CLASS: dict[str, float] = {
    "none": 0.8,
    "binary": 0.8,
    "multiple": 0.3,
    "consumable": 0.3,
}
PAPER_ORTOOLS_BY_CLASS: dict[str, float] = {
    "none": 0.6,
    "binary": 1.1,
    "multiple": 1.5,
    "consumable": 11.0,
}
SLOWEST_SHOWN = 12

#: What a table groups runs by (a size, a class, a point).
K = TypeVar("K")


def percentile(values: Sequence[float], q: float) -> float:
    """Linear-interpolation percentile (``q`` in 0..100) of ``values``."""
    ordered = sorted(values)
    if not ordered:
        return math.nan
    pos = (len(ordered) - 1) * q / 100
    low = math.floor(pos)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (pos - low)


@dataclass
class Row:
    """One line of a summary table; times in seconds."""

    solver: str
    group: str
    runs: int
    median: float
    p90: float
    mean: float
    build: float
    overhead: float
    solve: float
    timeouts: int
    check_failures: int
    paper: float | None


def _paper(solver: str, size: int | None, cls: str | None) -> float | None:
    ortools = solver.startswith("cpsat")
    if cls is not None:
        table = PAPER_ORTOOLS_BY_CLASS if ortools else PAPER_PROPOSED_BY_CLASS
        return table.get(cls)
    if size is not None and not ortools:
        return PAPER_PROPOSED_BY_SIZE.get(size)
    return None


def _row(solver: str, group: str, runs: list[Run], paper: float | None) -> Row:
    walls = [r.wall_s for r in runs]
    return Row(
        solver=solver,
        group=group,
        runs=len(runs),
        median=statistics.median(walls),
        p90=percentile(walls, 90),
        mean=statistics.fmean(walls),
        build=statistics.median(r.build_s for r in runs),
        overhead=statistics.median(r.overhead_s for r in runs),
        solve=statistics.median(r.solve_s for r in runs),
        timeouts=sum(r.timeout for r in runs),
        check_failures=sum(r.check_failed for r in runs),
        paper=paper,
    )


def _solvers(runs: Sequence[Run]) -> list[str]:
    return list(dict.fromkeys(r.solver for r in runs))


def _grouped(
    runs: Sequence[Run],
    keys: Sequence[K],
    key_of: Callable[[Run], K],
    label: Callable[[K], str],
    paper: Callable[[str, K], float | None],
) -> list[Row]:
    rows = []
    for solver in _solvers(runs):
        for key in keys:
            mine = [r for r in runs if r.solver == solver and key_of(r) == key]
            if mine:
                rows.append(_row(solver, label(key), mine, paper(solver, key)))
    return rows


def summarize(runs: Sequence[Run]) -> list[tuple[str, list[Row]]]:
    """Return titled tables: campaign by size, by class, scaling points.

    Parameters
    ----------
    runs
        Every run of the benchmark.

    Returns
    -------
    list of (title, rows)
        Only tables with at least one row.
    """
    camp = [r for r in runs if r.suite in ("campaign", "quick")]
    sections = [
        (
            "by number of tasks (H=336; paper Figure 3, proposed: "
            "0.2/0.6/0.9 s)",
            _grouped(
                camp,
                sorted({*CAMPAIGN_SIZES, *(r.num_tasks for r in camp)}),
                lambda r: r.num_tasks,
                lambda k: f"{k} tasks",
                lambda s, k: _paper(s, int(str(k)), None),
            ),
        ),
        (
            "by resource class, all sizes (paper Table 3)",
            _grouped(
                camp,
                CLASSES,
                lambda r: r.resource_class,
                str,
                lambda s, k: _paper(s, None, str(k)),
            ),
        ),
        (
            "by resource class, 10 tasks (paper Figure 4)",
            _grouped(
                [r for r in camp if r.num_tasks == 10],
                CLASSES,
                lambda r: r.resource_class,
                str,
                lambda s, k: _paper(s, None, str(k)),
            ),
        ),
    ]
    scale = [r for r in runs if r.suite == "scaling"]
    points = sorted({(r.horizon, r.num_tasks) for r in scale})
    sections.append(
        (
            "scaling (mixed resources)",
            _grouped(
                scale,
                points,
                lambda r: (r.horizon, r.num_tasks),
                lambda k: "H={} n={}".format(*k),
                lambda s, k: None,
            ),
        )
    )
    return [(title, rows) for title, rows in sections if rows]


def fmt(value: float | None) -> str:
    """Seconds with three decimals; "-" for a missing value."""
    if value is None or math.isnan(value):
        return "-"
    return f"{value:.3f}"


def aligned(cells: Sequence[Sequence[str]], left: int) -> list[str]:
    """Table rows with columns padded; the first ``left`` ones flush left."""
    widths = [max(len(c[i]) for c in cells) for i in range(len(cells[0]))]
    return [
        "  ".join(
            c.ljust(w) if i < left else c.rjust(w)
            for i, (c, w) in enumerate(zip(cell, widths, strict=True))
        )
        for cell in cells
    ]


HEADER = (
    "solver",
    "group",
    "runs",
    "median",
    "p90",
    "mean",
    "build",
    "overhd",
    "solve",
    "t/o",
    "chkfail",
    "paper",
)


def format_table(title: str, rows: Sequence[Row]) -> str:
    """Render one summary table as aligned text."""
    cells = [HEADER] + [
        (
            row.solver,
            row.group,
            str(row.runs),
            fmt(row.median),
            fmt(row.p90),
            fmt(row.mean),
            fmt(row.build),
            fmt(row.overhead),
            fmt(row.solve),
            str(row.timeouts),
            str(row.check_failures),
            fmt(row.paper) if row.paper is not None else "-",
        )
        for row in rows
    ]
    return "\n".join([f"== {title}", *aligned(cells, 2)])


def format_report(outcome: Outcome, *, time_limit: float | None) -> str:
    """Render the whole benchmark report.

    Parameters
    ----------
    outcome
        Runs and disagreements.
    time_limit
        The per-solve limit used, shown in the legend.

    Returns
    -------
    str
        Tables, the slowest runs, check failures and disagreements.
    """
    runs = outcome.runs
    limit = "none" if time_limit is None else f"{time_limit:g} s"
    parts = [
        "Wall time per solve in seconds (end to end: model build + solver "
        "overhead + solve); build/overhd/solve are medians. "
        f"t/o = no optimality proof within the limit ({limit}); "
        "chkfail = plans rejected by check_plan or solves that raised; "
        "paper = the paper's average (proposed ILP for cbc/highs, "
        "OR-Tools for cpsat*), on another machine.",
    ]
    parts += [format_table(title, rows) for title, rows in summarize(runs)]
    versus = format_versus(runs)
    if versus:
        parts.append(versus)
    scaled = format_scaling_versus(runs)
    if scaled:
        parts.append(scaled)
    shapes = format_shapes_versus(runs)
    if shapes:
        parts.append(shapes)
    slowest = sorted(runs, key=lambda r: r.wall_s, reverse=True)
    lines = ["== slowest solves"]
    lines += [
        f"{r.wall_s:8.3f} s  {r.solver:<7} {r.status:<10} {r.problem:<22} "
        f"seed {r.seed}  build {r.build_s:.3f} solve {r.solve_s:.3f}"
        for r in slowest[:SLOWEST_SHOWN]
    ]
    parts.append("\n".join(lines))
    failed = [r for r in runs if r.check_failed]
    lines = [f"== check failures: {len(failed)}"]
    lines += [
        f"{r.problem} (seed {r.seed}) {r.solver} {r.status}: "
        f"{r.error or r.check_detail}"
        for r in failed
    ]
    parts.append("\n".join(lines))
    lines = [f"== solver disagreements: {len(outcome.disagreements)}"]
    lines += [
        f"!!! {d.problem} (seed {d.seed}): {d.detail}"
        + (f"  [{d.path}]" if d.path else "")
        for d in outcome.disagreements
    ]
    parts.append("\n".join(lines))
    proven = {r.problem for r in runs if r.status == "optimal"}
    parts.append(
        f"{len(runs)} solves of {len({r.problem for r in runs})} problems; "
        f"{len(proven)} problems proven optimal by at least one solver."
    )
    return "\n\n".join(parts)


def _proved(run: Run) -> bool:
    return run.status in ("optimal", "infeasible") and not run.check_failed


def format_versus(runs: Sequence[Run], reference: str = "cpsat") -> str:
    """Each solver against ``reference`` on the campaign, problem by problem.

    Per size, per class, per class at the largest size (``15 binary``)
    and (when there are several) per horizon: both
    medians, their ratio, the median and worst of the per-problem ratios,
    the solver's mean time, how many problems each proved (optimal or
    infeasible), and how many the solver left ``unknown`` where the
    reference found a plan; those are also listed one by one, flagged.
    """
    camp = [r for r in runs if r.suite in ("campaign", "quick")]
    ref = {r.problem: r for r in camp if r.solver == reference}
    others = [s for s in _solvers(camp) if s != reference]
    if not ref or not others:
        return ""
    cells = [
        (
            "solver",
            "group",
            "n",
            "median",
            reference,
            "ratio",
            "median ratio",
            "worst ratio",
            "mean",
            "proved",
            f"{reference} proved",
            f"unknown, {reference} planned",
        )
    ]
    sizes = sorted({r.num_tasks for r in camp})
    classes = sorted(
        {r.resource_class for r in camp},
        key=lambda c: (*CLASSES, c).index(c),
    )
    horizons = sorted({r.horizon for r in camp})

    def having(
        size: int | None = None,
        cls: str | None = None,
        horizon: int | None = None,
    ) -> Callable[[Run], bool]:
        """Runs of this size, class and horizon (None: any)."""
        return lambda r: (
            (size is None or r.num_tasks == size)
            and (cls is None or r.resource_class == cls)
            and (horizon is None or r.horizon == horizon)
        )

    groups = [(f"{size} tasks", having(size=size)) for size in sizes]
    groups += [(cls, having(cls=cls)) for cls in classes]
    if len(sizes) > 1 and len(classes) > 1:
        # The largest size by class: the figures the targets are set on.
        top = sizes[-1]
        groups += [(f"{top} {cls}", having(top, cls)) for cls in classes]
    if len(horizons) > 1:
        groups += [(f"H={h}", having(horizon=h)) for h in horizons]
    groups.append(("overall", having()))
    lost = [
        r
        for r in camp
        if r.solver != reference
        and r.problem in ref
        and r.status == "unknown"
        and ref[r.problem].status in ("optimal", "feasible")
    ]
    for solver in others:
        for label, keep in groups:
            mine = [
                r
                for r in camp
                if r.solver == solver and keep(r) and r.problem in ref
            ]
            if not mine:
                continue
            theirs = [ref[r.problem] for r in mine]
            mine_median, ref_median, ratios = _times_against(mine, ref)
            cells.append(
                (
                    solver,
                    label,
                    str(len(mine)),
                    fmt(mine_median),
                    fmt(ref_median),
                    f"{mine_median / max(ref_median, 1e-4):.1f}x",
                    f"{statistics.median(ratios):.1f}x",
                    f"{max(ratios):.0f}x",
                    fmt(statistics.mean(r.wall_s for r in mine)),
                    f"{sum(_proved(r) for r in mine)}/{len(mine)}",
                    f"{sum(_proved(r) for r in theirs)}/{len(theirs)}",
                    str(sum(r in lost for r in mine)),
                )
            )
    flags = [
        f"!!! {r.solver} unknown on {r.problem} (seed {r.seed}, "
        f"{r.wall_s:.2f} s) where {reference} found a plan "
        f"({ref[r.problem].status}, total {ref[r.problem].total})"
        for r in lost
    ]
    targets = [
        _fifteen_target(solver, [r for r in camp if r.solver == solver], ref)
        for solver in others
    ]
    return "\n".join(
        [
            f"== campaign against {reference}, problem by problem",
            *aligned(cells, 2),
            f"{len(lost)} solves unknown where {reference} found a plan",
            *flags,
            *(line for line in targets if line),
        ]
    )


def _times_against(
    mine: list[Run], ref: dict[str, Run]
) -> tuple[float, float, list[float]]:
    """The median wall time of ``mine``, the reference's median on the
    same problems, and each problem's ratio of the two times (the
    reference's floored at 0.1 ms)."""
    ratios = [r.wall_s / max(ref[r.problem].wall_s, 1e-4) for r in mine]
    return (
        statistics.median(r.wall_s for r in mine),
        statistics.median(ref[r.problem].wall_s for r in mine),
        ratios,
    )


#: The 15-task target per resource class: the ratio of the medians to the
#: reference's and the worst problem's ratio at most these.
MEDIAN_TARGET = 3.0
WORST_TARGET = 20.0


def _fifteen_target(solver: str, mine: list[Run], ref: dict[str, Run]) -> str:
    """``solver``'s 15-task problems per class against the target (ratio
    of medians at most :data:`MEDIAN_TARGET`, worst problem at most
    :data:`WORST_TARGET`): the classes that meet it and those that do not,
    with their figures; empty without 15-task problems."""
    met: list[str] = []
    missed: list[str] = []
    order = (*CLASSES, *sorted({r.resource_class for r in mine}))
    for cls in dict.fromkeys(order):
        runs = [
            r
            for r in mine
            if r.num_tasks == 15
            and r.resource_class == cls
            and r.problem in ref
        ]
        if not runs:
            continue
        median, ref_median, ratios = _times_against(runs, ref)
        ratio, worst = median / max(ref_median, 1e-4), max(ratios)
        if ratio <= MEDIAN_TARGET and worst <= WORST_TARGET:
            met.append(cls)
        else:
            missed.append(f"{cls} ({ratio:.1f}x, worst {worst:.0f}x)")
    if not met and not missed:
        return ""
    return (
        f"{solver} at 15 tasks, target median <= {MEDIAN_TARGET:g}x and "
        f"worst <= {WORST_TARGET:g}x per class: met for "
        f"{', '.join(met) or 'none'}; NOT met for "
        f"{', '.join(missed) or 'none'}"
    )


def format_scaling_versus(
    runs: Sequence[Run], reference: str = "cpsat"
) -> str:
    """Scaling points: what each solver left out, against ``reference``.

    Per (horizon, tasks): median wall time, statuses, median left-out
    cost, the problems where the solver leaves less / as much / more out
    than ``reference``, and the median gap of its objective to the best
    bound any solver proved on the problem.
    """
    scale = [r for r in runs if r.suite == "scaling"]
    if not scale:
        return ""
    ref = {r.problem: r for r in scale if r.solver == reference}
    cells = [
        (
            "solver",
            "point",
            "median",
            "statuses",
            "left-out cost",
            f"vs {reference} less/same/more",
            "gap to best bound",
        )
    ]
    points = sorted({(r.horizon, r.num_tasks) for r in scale})
    for solver in _solvers(scale):
        for horizon, size in points:
            mine = [
                r
                for r in scale
                if r.solver == solver
                and (r.horizon, r.num_tasks) == (horizon, size)
            ]
            if not mine:
                continue
            statuses = ", ".join(
                f"{sum(r.status == s for r in mine)} {s}"
                for s in ("optimal", "feasible", "infeasible", "unknown")
                if any(r.status == s for r in mine)
            )
            left = [r.unscheduled_cost for r in mine if r.total is not None]
            versus = "-"
            if solver != reference and ref:
                less = same = more = 0
                for r in mine:
                    other = ref.get(r.problem)
                    if other is None or other.unscheduled_cost is None:
                        less += r.unscheduled_cost is not None
                        continue
                    if r.unscheduled_cost is None:
                        more += 1
                    elif r.unscheduled_cost < other.unscheduled_cost:
                        less += 1
                    elif r.unscheduled_cost == other.unscheduled_cost:
                        same += 1
                    else:
                        more += 1
                versus = f"{less}/{same}/{more}"
            gaps = []
            for r in mine:
                bounds = [
                    o.bound
                    for o in scale
                    if o.problem == r.problem and o.bound is not None
                ]
                if r.total is not None and bounds:
                    best = max(bounds)
                    gaps.append(100 * (r.total - best) / max(1, r.total))
            cells.append(
                (
                    solver,
                    f"H={horizon} n={size}",
                    fmt(statistics.median(r.wall_s for r in mine)),
                    statuses,
                    "-"
                    if not left
                    else f"{statistics.median(x or 0 for x in left):g}",
                    versus,
                    "-" if not gaps else f"{statistics.median(gaps):.1f} %",
                )
            )
    return "\n".join([f"== scaling against {reference}", *aligned(cells, 2)])


#: Suites of whole days (30-60 tasks) that :func:`format_shapes_versus`
#: sets against the reference problem by problem.
SHAPE_SUITES = ("large", "orbit", "infeasible")


def format_shapes_versus(runs: Sequence[Run], reference: str = "cpsat") -> str:
    """The large, orbit and infeasible suites against ``reference``.

    One line per problem: each solver's status, time and objective
    (schedule cost units left out in brackets) and how its answer stands
    against the reference's: proved by both, by one alone, a better or
    worse plan where neither proved. Then, per solver, the three
    targets of the large shapes: proved at least as many as the
    reference (optimal or infeasible, at the same limit), no
    ``unknown`` on a problem some solver proved infeasible, and the
    problems it left ``feasible`` that the reference proved optimal
    (the nearest a run can tell of "a problem the product can prove").
    With ``--repeat``, the first run of each is read.
    """
    days = [r for r in runs if r.suite in SHAPE_SUITES and r.repeat == 0]
    ref = {r.problem: r for r in days if r.solver == reference}
    others = [s for s in _solvers(days) if s != reference]
    if not ref or not others:
        return ""
    lines = [f"== large shapes against {reference}, problem by problem"]
    cells = [("problem", *others, reference, "against it")]
    problems = sorted({r.problem for r in days}, key=_shape_key)
    for name in problems:
        answers = {r.solver: r for r in days if r.problem == name}
        other = answers.get(reference)
        verdicts = [
            _against(answers[s], other) if s in answers else "-"
            for s in others
        ]
        cells.append(
            (
                name,
                *(_answer(answers.get(s)) for s in others),
                _answer(other),
                "; ".join(verdicts),
            )
        )
    lines += aligned(cells, 1)
    infeasible = {
        r.problem for r in days if r.status == "infeasible" and _proved(r)
    }
    for solver in others:
        mine = [r for r in days if r.solver == solver]
        proved = sum(_proved(r) for r in mine)
        theirs = sum(_proved(ref[r.problem]) for r in mine if r.problem in ref)
        unknown = sorted(
            r.problem
            for r in mine
            if r.problem in infeasible and r.status == "unknown"
        )
        short = sorted(
            r.problem
            for r in mine
            if r.status == "feasible"
            and r.problem in ref
            and ref[r.problem].status == "optimal"
            and _proved(ref[r.problem])
        )
        lines.append(
            f"{solver}: proved {proved} of {len(mine)}, {reference} "
            f"{theirs} ({'met' if proved >= theirs else 'NOT met'}: at "
            f"least as many); unknown on an infeasible problem: "
            f"{len(unknown)}{_listed(unknown)} "
            f"({'met' if not unknown else 'NOT met'}); feasible where "
            f"{reference} proved the optimum: {len(short)}{_listed(short)}"
        )
    return "\n".join(lines)


def _shape_key(name: str) -> tuple[str, int, str]:
    """Problems of a day suite by horizon, then size, then generator."""
    parts = name.split("-")
    digits = "".join(c for c in parts[0] if c.isdigit())
    return ("-".join(parts[1:]), int(digits or 0), parts[0])


def _answer(run: Run | None) -> str:
    """``status time objective [left out]``, or ``-`` without a run."""
    if run is None:
        return "-"
    text = f"{run.status} {run.wall_s:.2f} s"
    if run.check_failed:
        return text + " CHECK FAILED"
    if run.total is not None:
        text += f" {run.total:,}"
        if run.unscheduled_cost is not None:
            text += f" [{run.unscheduled_cost}]"
    return text


def _against(run: Run, other: Run | None) -> str:
    """How ``run`` stands against the reference's run of its problem."""
    if other is None:
        return "no reference run"
    mine, theirs = _proved(run), _proved(other)
    if mine and theirs:
        return "both proved"
    if mine:
        return "proved alone"
    if theirs:
        return f"{other.solver} alone proved"
    if run.total is None or other.total is None:
        return "no plan" if run.total is None else "a plan where it has none"
    if run.total < other.total:
        return f"better by {other.total - run.total:,}"
    if run.total > other.total:
        return f"worse by {run.total - other.total:,}"
    return "the same plan value"


def _listed(names: list[str]) -> str:
    return f" ({', '.join(names)})" if names else ""


def write_csv(
    runs: Sequence[Any], path: Path, *, append: bool = False
) -> None:
    """Write one CSV line per run (all fields of the runs' dataclass).

    With ``append``, add the lines to ``path`` (the header only when the
    file is new or empty).
    """
    if not runs:
        return
    names = [f.name for f in dataclasses.fields(runs[0])]
    fresh = not append or not path.exists() or path.stat().st_size == 0
    with path.open("w" if not append else "a", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=names)
        if fresh:
            writer.writeheader()
        for run in runs:
            writer.writerow(dataclasses.asdict(run))


def plot(runs: Sequence[Run], out_dir: Path) -> list[Path]:
    """Box plots like the paper's Figures 3 and 4 (and scaling).

    Parameters
    ----------
    runs
        Every run.
    out_dir
        Where the PNG files go.

    Returns
    -------
    list of Path
        The files written; empty when matplotlib is not installed.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return []
    camp = [r for r in runs if r.suite in ("campaign", "quick")]
    # File, title, runs, (key, label) per box group, the key of a run.
    figures: list[
        tuple[
            str,
            str,
            list[Run],
            list[tuple[object, str]],
            Callable[[Run], object],
        ]
    ] = [
        (
            "fig3_by_tasks.png",
            "Execution time by number of tasks (H = 336)",
            camp,
            [(s, f"{s}") for s in CAMPAIGN_SIZES],
            lambda r: r.num_tasks,
        ),
        (
            "fig4_by_class.png",
            "Execution time by resource class (10 tasks, H = 336)",
            [r for r in camp if r.num_tasks == 10],
            [(c, c) for c in CLASSES],
            lambda r: r.resource_class,
        ),
    ]
    scale = [r for r in runs if r.suite == "scaling"]
    points = sorted({(r.horizon, r.num_tasks) for r in scale})
    figures.append(
        (
            "scaling.png",
            "Execution time, mixed resources (scaling set)",
            scale,
            [(p, f"H{p[0]}\nn{p[1]}") for p in points],
            lambda r: (r.horizon, r.num_tasks),
        )
    )
    written = []
    for filename, title, subset, groups, key_of in figures:
        solvers = _solvers(subset)
        if not subset or not solvers:
            continue
        fig, ax = plt.subplots(figsize=(max(6, 1.6 * len(groups) + 2), 4.5))
        step = 0.8 / len(solvers)
        for si, solver in enumerate(solvers):
            data, positions = [], []
            for gi, (key, _) in enumerate(groups):
                walls = [
                    r.wall_s
                    for r in subset
                    if r.solver == solver and key_of(r) == key
                ]
                if walls:
                    data.append(walls)
                    positions.append(gi + (si - (len(solvers) - 1) / 2) * step)
            if not data:
                continue
            box = ax.boxplot(
                data,
                positions=positions,
                widths=step * 0.9,
                patch_artist=True,
                manage_ticks=False,
            )
            color = f"C{si}"
            for patch in box["boxes"]:
                patch.set_facecolor(color)
                patch.set_alpha(0.6)
            ax.plot([], [], color=color, linewidth=8, alpha=0.6, label=solver)
        ax.set_xticks(range(len(groups)), [label for _, label in groups])
        ax.set_ylabel("wall time [s]")
        ax.set_yscale("log")
        ax.set_title(title)
        ax.legend()
        ax.grid(axis="y", alpha=0.3)
        fig.tight_layout()
        path = out_dir / filename
        fig.savefig(path, dpi=120)
        plt.close(fig)
        written.append(path)
    return written
