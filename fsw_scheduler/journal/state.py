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

import contextlib
import hashlib
import logging
import os
import re
import shutil
import time
import zlib
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import msgspec

from ..errors import FieldIssue, InputError
from .integrity import FileCheck, check_folder
from .recover import is_finished, recover
from .replay import Rebuilt, rebuild

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    from ..model.problem import Problem

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
    set_aside
        Files moved out of the way (another session's, or the state of a
        replaced problem), never resumed.
    """

    next_journal: Path
    rebuilt: Rebuilt | None = None
    recovered: list[Path] = field(default_factory=list)
    removed: list[Path] = field(default_factory=list)
    set_aside: list[Path] = field(default_factory=list)


def damaged_files(folder: Path) -> list[FileCheck]:
    """The journal files of ``folder`` that are damaged (not merely cut
    short by a crash): a node must not resume from them (see
    :mod:`fsw_scheduler.journal.integrity`)."""
    if not folder.is_dir():
        return []
    return [c for c in check_folder(journal_files(folder)) if not c.ok]


#: The folder's identity, written at its first start.
IDENTITY = "identity.json"


class FolderIdentity(msgspec.Struct, frozen=True):
    """What a state folder belongs to: one spacecraft, one problem.

    ``problem_sha256`` names the problem the folder's first start was
    given (SHA-256 of its canonical encoding). The node id is not part of
    it: by default it changes at every start (``<host>-<pid>``).
    """

    spacecraft: str
    problem_sha256: str


#: The highest term this folder's node began, kept apart from the journal.
TERM_MARK = "term.json"


class _TermMark(msgspec.Struct, frozen=True):
    """``term.json``: a term and the CRC-32 of its decimal digits (a bit
    flip must not raise or lower it unseen)."""

    term: int
    crc32: int


def read_term_mark(folder: Path) -> int:
    """The highest term a node of ``folder`` began (0: none, or a mark
    that does not check out, said in the log).

    The journal holds each term as well; the mark outlives it when an
    operator moves a damaged run's files aside or the journal is lost, so
    a node resumed from older files still knows the term in use and
    begins above it with an alarm for what it lost, instead of reusing a
    term that receivers fence on.
    """
    path = folder / TERM_MARK
    try:
        mark = msgspec.json.decode(path.read_bytes(), type=_TermMark)
    except FileNotFoundError:
        return 0
    except (OSError, msgspec.DecodeError) as error:
        log.error("%s unreadable (%s): the journal's term alone", path, error)
        return 0
    if mark.term < 0 or zlib.crc32(str(mark.term).encode()) != mark.crc32:
        log.error("%s does not match its CRC: the journal's term alone", path)
        return 0
    return mark.term


def write_term_mark(
    folder: Path, term: int, replace: bool = False
) -> str | None:
    """Raise ``folder``'s term mark to ``term`` (never lowers it but to
    ``replace`` one not believed), on the disk before this returns.

    Returns
    -------
    str or None
        What went wrong (a disk fault, logged, not raised: the journal has
        the term too, and the node says it); None when the mark holds.
    """
    if not replace and read_term_mark(folder) >= term:
        return None
    mark = _TermMark(term, zlib.crc32(str(term).encode()))
    try:
        _write_synced(folder / TERM_MARK, msgspec.json.encode(mark))
    except OSError as error:
        fault = (
            f"cannot write {folder / TERM_MARK}: {error}: if this folder's "
            f"journal is lost too, a restart may begin term {term} again"
        )
        log.error("%s", fault)
        return fault
    return None


def problem_digest(problem: Problem) -> str:
    """The canonical name of ``problem``'s content."""
    return hashlib.sha256(msgspec.json.encode(problem)).hexdigest()


class _Head(NamedTuple):
    """What the head of a journal file says, read once."""

    has_config: bool = False
    opens_with_snapshot: bool = False
    identity: FolderIdentity | None = None
    version: str = ""


def _head(path: Path) -> _Head:
    """The node's settings and whether the state follows, from the first
    messages: a journal file starts with the settings, then (written by
    ``--state``) the engine's snapshot."""
    from ..wire import messages, topics
    from .reader import iter_messages

    head = _Head()
    try:
        for message in iter_messages(path):
            if not head.has_config and message.topic.endswith(
                "/" + topics.NODE_INFO
            ):
                info = msgspec.json.decode(
                    message.payload, type=messages.NodeInfo
                )
                identity = (
                    None
                    if info.problem is None
                    else FolderIdentity(
                        info.spacecraft, problem_digest(info.problem)
                    )
                )
                head = _Head(True, False, identity, info.version)
                continue
            opens = message.topic.endswith("/" + topics.SNAPSHOT)
            return head._replace(opens_with_snapshot=head.has_config and opens)
    except (ValueError, OSError, msgspec.DecodeError):
        return _Head()
    return head


def _newer(version: str) -> bool:
    """Whether ``version`` is of a newer release than this one."""
    from .. import __version__

    def parts(text: str) -> tuple[int, ...]:
        try:
            return tuple(int(p) for p in text.split(".")[:3])
        except ValueError:
            return (0,)

    return bool(version) and parts(version) > parts(__version__)


def _settle_identity(
    folder: Path,
    heads: dict[Path, _Head],
    start: StateStart,
    expected: FolderIdentity | None,
    replace: bool,
) -> list[Path]:
    """Check every journal file against the folder's identity: foreign
    ones set aside, newer ones refused, another problem refused unless
    ``replace`` (then the old state is set aside). The files to use."""
    from .. import __version__

    stamp = folder / IDENTITY
    files = list(heads)
    found = {
        path: (head.identity, head.version)
        for path, head in heads.items()
        if head.identity is not None
    }
    identity: FolderIdentity | None
    if stamp.exists():
        try:
            identity = msgspec.json.decode(
                stamp.read_bytes(), type=FolderIdentity
            )
        except (msgspec.DecodeError, msgspec.ValidationError) as error:
            raise InputError(
                [
                    FieldIssue(
                        f"--state {folder}",
                        f"{IDENTITY} is damaged ({error}); move it aside "
                        "to take the identity of the journal files",
                    )
                ],
                "state folder",
            ) from None
    else:
        first = next((f[0] for f in found.values()), None)
        identity = first or expected
    for path, seen in found.items():
        if _newer(seen[1]):
            raise InputError(
                [
                    FieldIssue(
                        f"--state {folder}",
                        f"{path.name} was written by version {seen[1]}, "
                        f"newer than this one ({__version__}): its format "
                        "may hold what this version cannot read; run the "
                        "newer version, or give another folder",
                    )
                ],
                "state folder",
            )
    if (
        expected is not None
        and identity is not None
        and identity.problem_sha256 != expected.problem_sha256
    ):
        if not replace:
            raise InputError(
                [
                    FieldIssue(
                        "--problem",
                        "differs from the problem this state folder "
                        "started from (sha256 "
                        f"{identity.problem_sha256[:12]}..., given "
                        f"{expected.problem_sha256[:12]}...): resuming "
                        "would ignore it; pass --new-problem to set the "
                        "folder's state aside and start from the new one",
                    )
                ],
                "arguments",
            )
        aside = _set_aside(folder, files, "replaced")
        start.set_aside += aside
        log.warning(
            "a new problem: the previous state is set aside in %s",
            aside[0].parent if aside else folder,
        )
        files, identity = [], expected
    keep = []
    for path in files:
        other = found.get(path)
        if identity is not None and other is not None and other[0] != identity:
            moved = _set_aside(folder, [path], "foreign")
            start.set_aside += moved
            log.warning(
                "%s belongs to another session (spacecraft %s, problem "
                "%s...): set aside in %s, never resumed",
                path.name,
                other[0].spacecraft,
                other[0].problem_sha256[:12],
                moved[0].parent,
            )
            continue
        keep.append(path)
    if identity is not None and not stamp.exists():
        try:
            _write_synced(stamp, msgspec.json.encode(identity))
        except OSError as error:  # written at a later start
            log.error("cannot write %s: %s", stamp, error)
    return keep


def _write_synced(path: Path, data: bytes) -> None:
    """Write a small file whole, on the disk with its name."""
    from .writer import sync_folder

    scratch = path.with_name(path.name + ".saving")
    with open(scratch, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    scratch.replace(path)
    sync_folder(path.parent)


def _set_aside(folder: Path, files: list[Path], why: str) -> list[Path]:
    """Move ``files`` into ``folder/<why>/`` (kept for an operator)."""
    place = folder / why
    place.mkdir(exist_ok=True)
    moved = []
    for path in files:
        target = place / path.name
        index = 1
        while target.exists():
            target = place / f"{path.stem}.{index}{path.suffix}"
            index += 1
        shutil.move(path, target)
        moved.append(target)
    stamp = folder / IDENTITY
    if why == "replaced" and stamp.exists():
        shutil.move(stamp, place / IDENTITY)
    return moved


def _finish_truncated(path: Path) -> bool:
    """Rewrite a file a killed writer left without its footer."""
    if is_finished(path):
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


def open_state(
    folder: Path,
    *,
    keep_runs: int = 20,
    identity: FolderIdentity | None = None,
    new_problem: bool = False,
) -> StateStart:
    """Prepare a state folder and rebuild what its journal holds.

    Parameters
    ----------
    folder
        Created if missing.
    keep_runs
        Runs (starts of the node) whose files are kept; older ones are
        deleted once the new run's journal exists. Only the newest file
        with a snapshot is needed to resume.
    identity
        The spacecraft and problem this start is given: a folder of
        another problem is refused (unless ``new_problem``); files of
        another session are set aside in ``foreign/``.
    new_problem
        Set a folder's state aside (in ``replaced/``) when the problem
        differs, and start from the new one.

    Returns
    -------
    StateStart
    """
    folder.mkdir(parents=True, exist_ok=True)
    for scratch in folder.glob("journal-*.mcap.saving"):
        # A standby's copy cut short by a reset: the one before it stands.
        scratch.unlink()
    damaged = damaged_files(folder)
    if damaged:
        raise StateDamaged(damaged)
    files = journal_files(folder)
    start = StateStart(next_journal=folder / "journal-0001.mcap")
    every = files
    heads = {path: _head(path) for path in files}
    files = _settle_identity(folder, heads, start, identity, new_problem)
    if not files:
        if every:
            start.next_journal = (
                folder / f"journal-{_run(every[-1]) + 1:04d}.mcap"
            )
        return start
    for path in files:
        try:
            if _finish_truncated(path):
                start.recovered.append(path)
        except OSError as error:  # a full disk: read it as it is
            log.error("cannot finish %s (%s): read as it is", path, error)
    for path in [p for p in files if not heads[p].has_config]:
        if _holds_nothing(path):
            # Killed between creating a part and writing its head (the
            # settings): nothing was journaled in it, nothing is lost.
            path.unlink()
            files.remove(path)
            start.removed.append(path)
            log.warning("%s holds no message: removed", path.name)
    if not files:
        start.next_journal = folder / f"journal-{_run(every[-1]) + 1:04d}.mcap"
        return start
    # The newest file that opens with a snapshot, and what came after it
    # (a file's head is the same once a truncated one is finished).
    base = max(
        (i for i, p in enumerate(files) if heads[p].opens_with_snapshot),
        default=0,
    )
    readable = [p for p in files[base:] if heads[p].has_config]
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


def _holds_nothing(path: Path) -> bool:
    """Whether a (finished) journal file holds no message at all."""
    from .reader import iter_messages

    try:
        return next(iter(iter_messages(path)), None) is None
    except (ValueError, OSError):
        return False


def run_number(path: Path) -> int:
    """The run number of a journal file name (``journal-<run>...``)."""
    return _run(path)


def _run(path: Path) -> int:
    """The run number of a journal file name."""
    match = _NAME.match(path.name)
    assert match is not None
    return int(match[1])


def prune(folder: Path, current: Path, max_bytes: int) -> list[Path]:
    """Delete the oldest journal files of ``folder`` while the folder's
    journals take more than ``max_bytes``; never ``current`` (which opens
    with the snapshot a resume needs, and is written now).

    Returns the files deleted, oldest first.
    """
    files = [p for p in journal_files(folder) if p != current]
    sizes = {p: p.stat().st_size for p in files}
    total = sum(sizes.values()) + (
        current.stat().st_size if current.exists() else 0
    )
    removed = []
    for path in files:
        if total <= max_bytes:
            break
        path.unlink()
        total -= sizes[path]
        removed.append(path)
    return removed


class StandbyStore:
    """A standby's copy of the shared state, kept in its own folder.

    A standby writes no journal of its own, yet the state it follows must
    survive a reset of both computers: each state it is shared (the
    commander's snapshot, as it came) is written as a journal part that
    holds the standby's settings and that snapshot, finished and synced
    (file and folder), and the part before it is then removed. The folder
    thus always holds one complete file with the newest saved state, and
    a start on it (:func:`open_state`) resumes from it like from any other
    part. Saves are coalesced: :meth:`offer` keeps the newest state,
    :meth:`save_due` writes it at most every ``every_s`` seconds (the
    caller's clock), so a standby's disk sees a bounded rate whatever the
    commander's step rate.

    Parameters
    ----------
    folder
        The standby's ``--state`` folder (opened by :func:`open_state`).
    run
        The run number its parts are written under (this start's).
    head
        ``(key, payload)`` of the settings message opening each part.
    snapshot_key
        The key the state is journaled under.
    schemas
        The journal's schema lookup.
    every_s
        The shortest time between two saves.
    """

    def __init__(
        self,
        folder: Path,
        run: int,
        head: tuple[str, bytes],
        snapshot_key: str,
        schemas: object = None,
        every_s: float = 0.2,
    ) -> None:
        self.folder = folder
        self.run = run
        self.head = head
        self.snapshot_key = snapshot_key
        self.every_s = every_s
        self.saves = 0
        self.fault: str | None = None
        self._schemas = schemas
        self._pending: Callable[[], bytes] | None = None
        self._offered = 0
        self._saved = 0
        self._part = 0
        self._last_s = float("-inf")
        self._current: Path | None = None

    def offer(self, source: Callable[[], bytes]) -> None:
        """The newest shared state, as what encodes it (called only when
        it is saved, at the next :meth:`save_due`)."""
        self._pending = source
        self._offered += 1

    def save_due(self, now_s: float, force: bool = False) -> bool:
        """Write the newest state offered if it is new and the last save
        is ``every_s`` old (``force``: now); True if one was written."""
        source = self._pending
        if source is None or self._offered == self._saved:
            return False
        if not force and now_s - self._last_s < self.every_s:
            return False
        self._last_s = now_s
        offered = self._offered
        try:
            self._write(source())
        except OSError as error:
            # A standby with a full disk still follows in memory.
            if self.fault is None:
                log.error("cannot save the shared state: %s", error)
            self.fault = f"{type(error).__name__}: {error}"
            return False
        self.fault = None
        self._saved = offered
        self.saves += 1
        return True

    def _write(self, payload: bytes) -> None:
        from .writer import Recorder, sync_folder

        newest = journal_files(self.folder)[-1:]
        if (
            newest
            and newest[0] != self._current
            and _run(newest[0]) >= self.run
        ):
            # This node commanded since (its journal is a later run): the
            # copy must sort after it, to be the state a start resumes.
            self.run, self._part = _run(newest[0]) + 1, 0
        self._part += 1
        path = self.folder / f"journal-{self.run:04d}-{self._part:03d}.mcap"
        # Written aside, then renamed: a part is whole or absent.
        scratch = path.with_name(path.name + ".saving")
        recorder = Recorder(
            scratch,
            schemas=self._schemas,  # type: ignore[arg-type]
            durable=True,
        )
        try:
            key, head = self.head
            # Wall time: a resume counts the time down from the last one.
            stamp = time.time_ns()
            recorder.write(key, head, log_time_ns=stamp)
            recorder.write(self.snapshot_key, payload, log_time_ns=stamp + 1)
            recorder.close()  # finished and synced
        except BaseException:
            with contextlib.suppress(OSError, ValueError):
                recorder.close()
            scratch.unlink(missing_ok=True)
            raise
        scratch.replace(path)
        sync_folder(self.folder)
        previous, self._current = self._current, path
        if previous is not None:
            previous.unlink(missing_ok=True)
