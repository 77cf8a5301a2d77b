"""Pages of a large Gantt chart: which rows go on which page, and its file.

Pure: no matplotlib, no file access. A Gantt with more task rows than
:data:`ROWS_PER_PAGE` is drawn as several pages (see
:func:`fsw_scheduler.view.gantt.gantt` for why pages and not one tall
figure); this module decides the split and the names, so both are
deterministic and can be tested without drawing.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence

__all__ = [
    "ROWS_PER_PAGE",
    "Page",
    "page_path",
    "split_rows",
]

#: Most task rows on one page. At the Gantt's 0.34 in per row and 110 dpi
#: that is a task panel of at most 14.5 in (about 1,600 px), which a
#: screen shows at full size with the row names still legible; the
#: resource panels under it add a height that depends on the number of
#: resources, never on the number of tasks.
ROWS_PER_PAGE = 40


@dataclass(frozen=True)
class Page:
    """The rows of one page.

    Attributes
    ----------
    number
        1-based page number.
    count
        How many pages the chart has.
    first
        1-based index of the page's first row among all rows.
    rows
        The task ids on this page, in chart order.
    total
        How many rows the whole chart has.
    """

    number: int
    count: int
    first: int
    rows: tuple[str, ...]
    total: int

    @property
    def last(self) -> int:
        """1-based index of the page's last row among all rows."""
        return self.first + len(self.rows) - 1

    @property
    def heading(self) -> str:
        """``rows a\u2013b of N (page i of n)``, the page's title line."""
        return (
            f"rows {self.first}\u2013{self.last} of {self.total} "
            f"(page {self.number} of {self.count})"
        )


def split_rows(
    rows: Sequence[str], per_page: int = ROWS_PER_PAGE
) -> list[Page]:
    """Cut the rows, in their order, into as few pages as hold them.

    The pages are as even as can be (sizes differ by at most one, the
    longer ones first) rather than full pages and a short last one: the
    pages then have the same row pitch and height, so the same time is at
    the same place on every page when flipping through them.

    Parameters
    ----------
    rows
        All task rows in chart order.
    per_page
        At most this many rows on a page (>= 1).

    Returns
    -------
    list of Page
        One page when ``len(rows) <= per_page`` (also when there is no
        row at all), else ``ceil(len(rows) / per_page)`` pages.

    Raises
    ------
    ValueError
        If ``per_page`` is below 1.
    """
    if per_page < 1:
        raise ValueError(f"per_page must be at least 1, not {per_page}")
    total = len(rows)
    count = max(1, -(-total // per_page))
    size, extra = divmod(total, count)
    pages: list[Page] = []
    at = 0
    for idx in range(count):
        length = size + (1 if idx < extra else 0)
        pages.append(
            Page(idx + 1, count, at + 1, tuple(rows[at : at + length]), total)
        )
        at += length
    return pages


def page_path(path: str | Path, page: Page) -> Path:
    """Where a page is written: ``path`` itself for a one-page chart, else
    ``<stem>-<number><suffix>`` next to it (``plan.png`` gives
    ``plan-1.png``, ``plan-2.png``, ...)."""
    path = Path(path)
    if page.count == 1:
        return path
    return path.with_name(f"{path.stem}-{page.number}{path.suffix}")
