"""Tests of the locks: the demo's part of the lock is current, a subset of
it byte for byte, and holds no development or benchmark tool."""

from __future__ import annotations

import re
import subprocess
import sys

from ..factories import ROOT, TOOLS

LOCK = ROOT / "requirements-lock.txt"
DEMO = ROOT / "requirements-demo.txt"
#: What tools/demo must not install (the issue's list and their kin).
DEVELOPMENT = {
    "ortools",
    "pandas",
    "mypy",
    "ruff",
    "hypothesis",
    "gitpython",
    "pytest",
    "import-linter",
    "jsonschema",
    "highspy",
    "cryptography",
}
_ENTRY = re.compile(r"^([A-Za-z0-9][A-Za-z0-9._-]*)==(\S+) \\$", re.M)


def _entries(text: str) -> dict[str, str]:
    return {
        re.sub(r"[-_.]+", "-", name).lower(): version
        for name, version in _ENTRY.findall(text)
    }


def _blocks(text: str) -> dict[str, str]:
    """Each entry's pin and hashes (the lines up to its comments)."""
    out = {}
    for block in re.split(r"\n(?=[A-Za-z0-9])", text):
        head = block.split("\n", 1)[0]
        match = _ENTRY.match(head)
        if match:
            out[match.group(1)] = "\n".join(
                line for line in block.splitlines() if "--hash" in line
            )
    return out


def test_the_demo_lock_is_current() -> None:
    """Tests that requirements-demo.txt is what tools/lock_subset makes of
    the lock and pyproject.toml (tools/lock writes both)."""
    done = subprocess.run(
        [sys.executable, str(TOOLS / "lock_subset"), "--check"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_demo_lock_is_the_runtime_part_of_the_lock() -> None:
    """Tests the demo's lock: the package's dependencies and the pictures'
    are in it, no development or benchmark tool is, and every entry has
    the lock's version and hashes."""
    lock, demo = _entries(LOCK.read_text()), _entries(DEMO.read_text())
    for needed in ("eclipse-zenoh", "pulp", "msgspec", "mcap", "matplotlib"):
        assert needed in demo, needed
    assert not DEVELOPMENT & set(demo), DEVELOPMENT & set(demo)
    assert len(demo) < len(lock) / 2, (len(demo), len(lock))
    for name, version in demo.items():
        assert lock[name] == version, name
    locked = _blocks(LOCK.read_text())
    for name, hashes in _blocks(DEMO.read_text()).items():
        assert hashes == locked[name], name
