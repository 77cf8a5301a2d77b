"""A node's state folder (``run --state DIR``): its journal, resumed.

The journal is the node's state. Every start writes a new file
``journal-<run>.mcap`` into the folder; a file that grows past the size
limit continues in ``journal-<run>-<part>.mcap``. Each file opens with the
node's settings and a snapshot of the engine's state, then holds every
input and output in processing order, each step on disk before its outputs
reach the bus. On start, :func:`open_state` finishes any file a killed
node left truncated, rebuilds the engine from the newest snapshot and the
messages after it (no solver run: solve results are in the journal), and
names the file to write next.
"""

from __future__ import annotations

import logging
import re
import shutil
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from .recording import _is_finished, recover
from .replay import Rebuilt, _opening_snapshot, read_node_info, rebuild

if TYPE_CHECKING:
    from pathlib import Path

log = logging.getLogger("fsw_scheduler.state")

_NAME = re.compile(r"^journal-(\d{4,})(?:-(\d{3,}))?\.mcap$")


def journal_files(folder: Path) -> list[Path]:
    """The journal files of ``folder`` in writing order (run, then part)."""
    found = []
    for path in folder.glob("journal-*.mcap"):
        match = _NAME.match(path.name)
        if match:
            found.append(((int(match[1]), int(match[2] or 0)), path))
    return [path for _, path in sorted(found)]


@dataclass
class StateStart:
    """What a node starting on a state folder needs.

    Attributes
    ----------
    next_journal
        The file to journal into now.
    rebuilt
        The engine rebuilt from the journal, None for a new folder.
    recovered
        Truncated files that were finished (their complete messages kept).
    removed
        Old runs deleted beyond the retention count.
    """

    next_journal: Path
    rebuilt: Rebuilt | None = None
    recovered: list[Path] = field(default_factory=list)
    removed: list[Path] = field(default_factory=list)


def _finish_truncated(path: Path) -> bool:
    """Rewrite a file a killed writer left without its footer."""
    if _is_finished(path):
        return False
    scratch = path.with_name(path.name + ".recovering")
    kept = recover(path, scratch)
    shutil.move(scratch, path)
    log.warning(
        "%s was truncated: finished it with %d messages",
        path,
        sum(kept.values()),
    )
    return True


def _starts_with_snapshot(path: Path) -> bool:
    from .bus.topics import Topics
    from .recording import iter_messages

    try:
        recorded = list(iter_messages(path))
        info, _ = read_node_info(recorded)
    except (ValueError, OSError):
        return False
    return _opening_snapshot(recorded, Topics(info.spacecraft)) is not None


def open_state(folder: Path, *, keep_runs: int = 20) -> StateStart:
    """Prepare a state folder and rebuild what its journal holds.

    Parameters
    ----------
    folder
        Created if missing.
    keep_runs
        Runs (starts of the node) whose files are kept; older ones are
        deleted once the new run's journal exists. Only the newest file
        with a snapshot is needed to resume.

    Returns
    -------
    StateStart
    """
    folder.mkdir(parents=True, exist_ok=True)
    files = journal_files(folder)
    start = StateStart(next_journal=folder / "journal-0001.mcap")
    if not files:
        return start
    for path in files:
        if _finish_truncated(path):
            start.recovered.append(path)
    # The newest file that opens with a snapshot, and what came after it.
    base = 0
    for idx in range(len(files) - 1, -1, -1):
        if _starts_with_snapshot(files[idx]):
            base = idx
            break
    readable = [p for p in files[base:] if _has_config(p)]
    if readable:
        start.rebuilt = rebuild(readable)
    start.next_journal = folder / f"journal-{_run(files[-1]) + 1:04d}.mcap"
    # Never the run resumed from: its snapshot is the state until the new
    # journal's own snapshot is on disk.
    runs = sorted({_run(p) for p in files if _run(p) < _run(files[base])})
    for old in runs[: max(len(runs) + 1 - keep_runs, 0)]:
        for path in files:
            if _run(path) == old:
                path.unlink()
                start.removed.append(path)
    return start


def _run(path: Path) -> int:
    """The run number of a journal file name."""
    match = _NAME.match(path.name)
    assert match is not None
    return int(match[1])


def _has_config(path: Path) -> bool:
    from .recording import iter_messages

    try:
        read_node_info(list(iter_messages(path)))
    except (ValueError, OSError):
        return False
    return True
