"""Colours of the pictures, and the import of matplotlib when they are drawn.

matplotlib is an optional dependency (``fsw-scheduler[plot]``): nothing here
imports it at module level, so the view modules stay cheap to import and
work without it until a picture is asked for.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..model.problem import Problem, Task

__all__ = [
    "CHARGE_COLOUR",
    "CLOSED_COLOUR",
    "DRAIN_COLOUR",
    "FAILED_COLOUR",
    "GHOST_COLOUR",
    "GHOST_FILL",
    "LOST_COLOUR",
    "MEASURED_COLOUR",
    "NOW_COLOUR",
    "NO_BINARY_COLOUR",
    "PALETTE",
    "PIN_COLOUR",
    "PLOT_INSTALL_HINT",
    "REMOVED_COLOUR",
    "UNSCHEDULED_COLOUR",
    "colour_of",
    "have_matplotlib",
    "load_matplotlib",
]


_INSTALL_HINT = (
    "fsw_scheduler.view needs matplotlib; install it with "
    "pip install 'fsw-scheduler[plot]'"
)


def have_matplotlib() -> bool:
    """Whether the pictures can be drawn (matplotlib importable).

    Checked before any work is done, so that a command never solves for
    minutes and then fails on a missing optional dependency.
    """
    try:
        from matplotlib.backends.backend_agg import (  # noqa: F401
            FigureCanvasAgg,
        )
    except ImportError:
        return False
    return True


PLOT_INSTALL_HINT = "pip install 'fsw-scheduler[plot]'"


def load_matplotlib() -> tuple[Any, Any, Any]:
    """Import the few matplotlib pieces the pictures need.

    The figure is drawn on an explicit Agg canvas instead of through
    ``matplotlib.use("Agg")`` and pyplot: the result is the same headless
    PNG, but a library call must not switch the backend of a user's
    interactive session, and a figure that pyplot never saw cannot leak
    into its figure registry, so nothing has to be closed.
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.patches import Patch
    except ImportError as error:
        raise ImportError(_INSTALL_HINT) from error
    return Figure, FigureCanvasAgg, Patch


#: Colours of the binary resources, in declaration order: colour-blind
#: friendly (Okabe-Ito), then tab10 for long resource lists.
PALETTE = (
    "#0072B2",
    "#E69F00",
    "#009E73",
    "#CC79A7",
    "#56B4E9",
    "#D55E00",
    "#F0E442",
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
)


#: A task that uses no binary resource.
NO_BINARY_COLOUR = "#7f7f7f"


#: The hatching across the row of a task left out of the plan.
UNSCHEDULED_COLOUR = "#d9d9d9"


#: The line at the current time unit.
NOW_COLOUR = "#c0392b"
#: A failed execution: hatched in this colour, never drawn as finished.
FAILED_COLOUR = "#b03a2e"


def colour_of(problem: Problem, task: Task | None) -> str:
    """Colour of a task: its first binary resource in declaration order."""
    if task is None:
        return NO_BINARY_COLOUR
    for idx, name in enumerate(problem.resources.binary):
        if name in task.uses:
            return PALETTE[idx % len(PALETTE)]
    return NO_BINARY_COLOUR


#: Charge lost because the store was full.
LOST_COLOUR = "#e9c46a"
#: Units an external rate charges a store (sunlight), behind its level.
CHARGE_COLOUR = "#f4d35e"
#: Units an external rate drains a store (a heater), behind its level.
DRAIN_COLOUR = "#8ecae6"
#: A binary resource outside its availability windows, behind its lane.
CLOSED_COLOUR = "#e3e3e3"

#: A task a replan removed: its outline and the rule's note.
REMOVED_COLOUR = "#9a9a9a"
#: The old place of a moved activity: a faint fill, a dashed outline.
GHOST_COLOUR = "#7b52ae"
GHOST_FILL = "#f1ecf7"
#: The outline and mark of an activity a commit window pinned.
PIN_COLOUR = "#1a1a80"


#: A measured level.
MEASURED_COLOUR = "#D55E00"
