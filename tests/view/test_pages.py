"""Tests of the split of a Gantt's rows into pages (view.pages)."""

from __future__ import annotations

from pathlib import Path

import pytest

from fsw_scheduler.view.pages import (
    ROWS_PER_PAGE,
    page_path,
    split_rows,
)


def _rows(count: int) -> list[str]:
    return [f"T{idx:03d}" for idx in range(count)]


@pytest.mark.parametrize("count", [0, 1, ROWS_PER_PAGE])
def test_rows_that_fit_make_one_page_under_the_given_name(count: int) -> None:
    """Tests that up to the limit there is one page, written as asked."""
    (page,) = split_rows(_rows(count))
    assert page.rows == tuple(_rows(count))
    assert page_path("out/plan.png", page) == Path("out/plan.png")


def test_pages_are_even_and_keep_the_order() -> None:
    """Tests that 150 rows make 4 pages of 38, 38, 37, 37 rows, in order,
    every row once, numbered and titled."""
    rows = _rows(150)
    pages = split_rows(rows)
    assert [len(p.rows) for p in pages] == [38, 38, 37, 37]
    assert [row for p in pages for row in p.rows] == rows
    assert [(p.first, p.last) for p in pages] == [
        (1, 38),
        (39, 76),
        (77, 113),
        (114, 150),
    ]
    assert pages[1].heading == "rows 39\u201376 of 150 (page 2 of 4)"
    assert split_rows(rows) == pages  # deterministic


def test_one_row_over_the_limit_makes_two_pages() -> None:
    """Tests the limit itself: 41 rows give two pages of 21 and 20."""
    pages = split_rows(_rows(ROWS_PER_PAGE + 1))
    assert [len(p.rows) for p in pages] == [21, 20]
    assert all(len(p.rows) <= ROWS_PER_PAGE for p in pages)


def test_page_files_are_numbered_next_to_the_path() -> None:
    """Tests the names of the pages: ``<stem>-<n><suffix>``."""
    pages = split_rows(_rows(100), per_page=10)
    names = [page_path(Path("out/plan-3.png"), p) for p in pages]
    assert names[0] == Path("out/plan-3-1.png")
    assert names[-1] == Path("out/plan-3-10.png")
    assert len(set(names)) == 10


def test_a_page_must_hold_a_row() -> None:
    """Tests that a page size below 1 is refused."""
    with pytest.raises(ValueError, match="per_page"):
        split_rows(_rows(3), per_page=0)
