"""Tests of the terms' range and the jumps a node believes."""

from __future__ import annotations

import pytest

from fsw_scheduler.wire.terms import MAX_TERM, MAX_TERM_JUMP, term_refused


@pytest.mark.parametrize(
    ("term", "verified", "words"),
    [
        (MAX_TERM + 1, MAX_TERM, "outside"),
        (-1, 0, "outside"),
        (10**40, 0, "outside"),
        (MAX_TERM, 0, "jumps"),
        (MAX_TERM_JUMP + 3, 2, "jumps"),
        (True, 0, "not an integer"),
        (2.0, 0, "not an integer"),
        ("3", 0, "not an integer"),
    ],
)
def test_terms_outside_the_rules_are_refused(
    term: object, verified: int, words: str
) -> None:
    """Tests that a term beyond int64, negative, not an integer, or a jump
    beyond the bound over the highest verified term is refused, saying
    why."""
    refused = term_refused(term, verified)
    assert refused is not None and words in refused


@pytest.mark.parametrize(
    ("term", "verified"),
    [
        (0, 0),
        (1, 0),
        (7, 7),
        (3, 9),
        (MAX_TERM_JUMP + 2, 2),
        (MAX_TERM, MAX_TERM),
    ],
)
def test_terms_within_the_rules_are_believed(term: int, verified: int) -> None:
    """Tests that a lower, equal or boundedly higher term is believed."""
    assert term_refused(term, verified) is None
