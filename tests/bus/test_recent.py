"""Tests of the bounded memory of ids."""

from __future__ import annotations

import pytest

from fsw_scheduler.bus.recent import Recent


def test_the_newest_keys_stay_and_a_key_put_again_is_the_newest() -> None:
    """Tests that a memory of three keeps the three put last, that a key
    put again moves to the newest end (it outlives keys put before it),
    and that a key popped is forgotten with its value returned."""
    memory: Recent[int] = Recent(3)
    for n, key in enumerate("abc"):
        memory.put(key, n)
    memory.put("a", 10)  # again: the newest now
    memory.put("d", 3)  # forgets "b", put longest ago
    assert "b" not in memory and "a" in memory and len(memory) == 3
    assert memory.pop("a") == 10 and "a" not in memory
    assert memory.pop("a") is None
    for n in range(10_000):
        memory.put(f"flood-{n}", n)
    assert len(memory) == 3 and "flood-9999" in memory and "d" not in memory
    with pytest.raises(ValueError, match="limit 0"):
        Recent(0)
