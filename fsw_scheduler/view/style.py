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
    "PLOT_INSTALL_HINT",
    "have_matplotlib",
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


def _load_matplotlib() -> tuple[Any, Any, Any]:
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


# Colour-blind friendly (Okabe-Ito), then tab10 for long resource lists.
_PALETTE = (
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


_NO_BINARY = "#7f7f7f"


_UNSCHEDULED = "#d9d9d9"


_NOW = "#c0392b"
#: A failed execution: hatched in this colour, never drawn as finished.
_FAILED = "#b03a2e"


def _colour_of(problem: Problem, task: Task | None) -> str:
    """Colour of a task: its first binary resource in declaration order."""
    if task is None:
        return _NO_BINARY
    for idx, name in enumerate(problem.resources.binary):
        if name in task.uses:
            return _PALETTE[idx % len(_PALETTE)]
    return _NO_BINARY


_LOST = "#e9c46a"

_REMOVED = "#9a9a9a"


_MEASURED = "#D55E00"
