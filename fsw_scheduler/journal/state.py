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

from ..errors import FieldIssue, InputError
from .integrity import FileCheck, check_folder
from .recover import _is_finished, recover
from .replay import Rebuilt, rebuild

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


class StateDamaged(InputError):
    """A state folder holds damaged journal files: it is not resumed.

    Resuming from the intact part would start from a state older than the
    one the bus saw (goals accepted, activities commanded after it), so
    the node refuses (exit 2, each file named with the byte offset of the
    damage); an operator moves the damaged files aside (``state check``
    says what is intact) or gives a new folder. A hot standby commands
    meanwhile.
    """

    def __init__(self, damaged: list[FileCheck]) -> None:
        self.damaged = damaged
        super().__init__(
            [
                FieldIssue(
                    f"--state {c.path.parent}",
                    c.describe()
                    + "; move it aside to resume from the other files",
                )
                for c in damaged
            ],
            "state folder (damaged journal)",
        )


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


def damaged_files(folder: Path) -> list[FileCheck]:
    """The journal files of ``folder`` that are damaged (not merely cut
    short by a crash): a node must not resume from them (see
    :mod:`fsw_scheduler.journal.integrity`)."""
    if not folder.is_dir():
        return []
    return [c for c in check_folder(journal_files(folder)) if not c.ok]


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


def _opening(path: Path) -> tuple[bool, bool]:
    """(has the node's settings, opens with a snapshot), from its head.

    Only the first messages are read: a journal file starts with the
    settings, then (written by ``--state``) the engine's snapshot.
    """
    from ..wire import topics
    from .reader import iter_messages

    has_config = False
    try:
        for message in iter_messages(path):
            if message.topic.endswith("/" + topics.NODE_INFO):
                has_config = True
                continue
            opens = message.topic.endswith("/" + topics.SNAPSHOT)
            return has_config, has_config and opens
    except (ValueError, OSError):
        return False, False
    return has_config, False


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
    damaged = damaged_files(folder)
    if damaged:
        raise StateDamaged(damaged)
    files = journal_files(folder)
    start = StateStart(next_journal=folder / "journal-0001.mcap")
    if not files:
        return start
    for path in files:
        if _finish_truncated(path):
            start.recovered.append(path)
    # The newest file that opens with a snapshot, and what came after it.
    heads = [_opening(path) for path in files]
    base = max((i for i, (_, opens) in enumerate(heads) if opens), default=0)
    readable = [
        path
        for path, (config, _) in list(zip(files, heads, strict=True))[base:]
        if config
    ]
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
