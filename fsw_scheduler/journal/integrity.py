"""Integrity of journal files: what is intact, and where damage starts.

Every read that feeds a decision (resume, takeover from a state folder)
first walks each file record by record: record sizes are bounded before
anything is allocated, every chunk is decompressed and its CRC checked,
and a finished file's summary is checked against the CRC in its footer;
a metadata record (which MCAP leaves without a CRC: the settings a
resume reads) against its own (``_crc32``, from the writer).
Every record type but a bare message has fields whose sizes add up to
its length field, so a length field is checked against them: one flipped
past the end of the file is not mistaken for a record a crash cut short
(whose fields run past the end as well). A file cut short by a crash
(its last record incomplete, nothing after it) is *truncated*:
:func:`~fsw_scheduler.journal.recover.recover` finishes it. Anything
else is *damage* (a bit flip, a torn write inside the file, another
program's bytes), named with its byte offset; a state folder with damage
is refused (``run`` exits 2 naming file and offset) rather than resumed
into a state the bus never saw. ``fsw-scheduler
state check DIR`` prints this for an operator.
"""

from __future__ import annotations

import io
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import Attachment, Chunk, Message, Metadata
from mcap.stream_reader import StreamReader, breakup_chunk

from .metadata import metadata_intact
from .writer import MCAP_MAGIC, RECORD_HEAD, PathLike

#: The largest record a journal holds (a chunk of messages, or one large
#: message: a snapshot, an attachment), with room to spare. A length field
#: beyond it is damage, not an allocation.
MAX_RECORD_BYTES = 256 << 20
_KNOWN = frozenset(int(op) for op in Opcode)
_FOOTER = struct.Struct("<QQI")


@dataclass
class FileCheck:
    """What :func:`check_file` found in one file.

    Attributes
    ----------
    path
        The file.
    messages
        Messages intact before any damage.
    finished
        Whether it ends with a footer (closed by its writer).
    damage
        What is wrong, None when nothing is.
    offset
        Byte offset of the damaged record (None: no damage).
    """

    path: Path
    messages: int = 0
    finished: bool = False
    damage: str | None = None
    offset: int | None = None

    @property
    def ok(self) -> bool:
        """No damage (a truncated file is not damaged: it is finished)."""
        return self.damage is None

    def describe(self) -> str:
        """One line for an operator."""
        if self.damage is not None:
            return (
                f"{self.path.name}: DAMAGED at byte {self.offset}: "
                f"{self.damage} ({self.messages} messages intact before it)"
            )
        state = "finished" if self.finished else "truncated (a crash)"
        return f"{self.path.name}: intact, {state}, {self.messages} messages"


def check_file(path: PathLike) -> FileCheck:
    """Walk ``path`` record by record and say what is intact.

    Never raises for the contents of the file (only for an unreadable
    file: ``OSError``).
    """
    path = Path(path)
    data = path.read_bytes()
    result = FileCheck(path)
    if len(data) < len(MCAP_MAGIC) and MCAP_MAGIC.startswith(data):
        # A writer killed while it opened the file (rotation, a new run):
        # nothing was written to it, so nothing is lost.
        return result
    if data[: len(MCAP_MAGIC)] != MCAP_MAGIC:
        if not any(data):
            return result  # zeros only: a power cut at its start
        result.damage, result.offset = "not an MCAP file (bad magic)", 0
        return result
    at = len(MCAP_MAGIC)
    ends = data.endswith(MCAP_MAGIC) and len(data) >= 2 * len(MCAP_MAGIC)
    while True:
        if at + RECORD_HEAD.size > len(data):
            if ends:
                result.damage, result.offset = "ends before its footer", at
            return result
        opcode, length = RECORD_HEAD.unpack_from(data, at)
        end = at + RECORD_HEAD.size + length
        if opcode not in _KNOWN or opcode == 0:
            if not ends and not any(data[at:]):
                return result  # zeros after a power cut: truncated
            result.damage = f"unknown record type {opcode}"
            result.offset = at
            return result
        if length > MAX_RECORD_BYTES:
            result.damage = (
                f"a record of {length} bytes (the limit is {MAX_RECORD_BYTES})"
            )
            result.offset = at
            return result
        if end > len(data):
            if ends:
                result.damage = "a record runs past the end of the file"
                result.offset = at
            else:
                _check_cut(data, at, opcode, length, result)
            return result
        own = _fields_length(data, at + RECORD_HEAD.size, opcode)
        issue: str | None
        if own is not None and own != length:
            issue = f"its length field says {length} bytes, its fields {own}"
        else:
            issue = _record_issue(data, at, end, result)
        if issue is not None:
            result.damage, result.offset = issue, at
            return result
        if opcode == Opcode.FOOTER:
            result.finished = end + len(MCAP_MAGIC) == len(data) and ends
            issue = _summary_issue(data, at) or _index_issue(data)
            if issue is not None:
                result.damage, result.offset = issue, at
            elif not result.finished:
                result.damage = "bytes after the footer"
                result.offset = end
            return result
        at = end


#: The fields of each record type in order (MCAP specification): ``B``,
#: ``H``, ``I``, ``Q`` fixed integers; ``s`` a string or map (a ``uint32``
#: byte length, then the bytes); ``b`` bytes with a ``uint64`` length.
#: Every record's fields but a bare message's add up to its length field,
#: which is what tells a length flipped past the end of the file from a
#: record a crash cut short (:func:`_check_cut`).
_FIELDS: dict[int, str] = {
    Opcode.HEADER: "ss",
    Opcode.FOOTER: "QQI",
    Opcode.SCHEMA: "Hsss",
    Opcode.CHANNEL: "HHsss",
    Opcode.CHUNK: "QQQIsb",
    Opcode.MESSAGE_INDEX: "Hs",
    Opcode.CHUNK_INDEX: "QQQQsQsQQ",
    Opcode.ATTACHMENT: "QQssbI",
    Opcode.ATTACHMENT_INDEX: "QQQQQss",
    Opcode.STATISTICS: "QHIIIIQQs",
    Opcode.METADATA: "ss",
    Opcode.METADATA_INDEX: "QQs",
    Opcode.SUMMARY_OFFSET: "BQQ",
    Opcode.DATA_END: "I",
}
_FIXED = {"B": 1, "H": 2, "I": 4, "Q": 8}


def _fields_length(data: bytes, body: int, opcode: int) -> int | None:
    """The length a record's own fields give it (from ``body``, the byte
    after its head); None when they run past the end of ``data`` (a cut
    record) or the record type has no such sum (a bare message)."""
    fields = _FIELDS.get(opcode)
    if fields is None:
        return None
    at = body
    for kind in fields:
        if kind in _FIXED:
            at += _FIXED[kind]
            continue
        width = 4 if kind == "s" else 8
        if at + width > len(data):
            return None
        (size,) = struct.unpack_from("<I" if width == 4 else "<Q", data, at)
        at += width + size
    return at - body if at <= len(data) else None


def _check_cut(
    data: bytes, at: int, opcode: int, length: int, result: FileCheck
) -> None:
    """Tell a record a crash cut short from a length field damaged upwards.

    Both run past the end of an unfinished file. A crash writes the head
    and the fields as one, so a cut record's fields run past the end too;
    a flipped length leaves fields that end inside the file, followed by
    the records that were written after it. The second is damage: read as
    a crash, everything after it would be dropped without a word.
    """
    body = at + RECORD_HEAD.size
    own = _fields_length(data, body, opcode)
    if own is None or own == length:
        return
    nxt = body + own
    if nxt < len(data) and not _starts_record(data, nxt):
        # What follows is no record (zeros, torn pages after a power
        # cut): the fields read garbage, the record was cut.
        return
    result.damage = (
        f"its length field says {length} bytes, past the end of the file; "
        f"its fields fill {own} and records follow them"
    )
    result.offset = at


def _starts_record(data: bytes, at: int) -> bool:
    """Whether a record that checks out (or is cut by the file's end)
    starts at ``at``."""
    if at + RECORD_HEAD.size > len(data):
        return False
    opcode, length = RECORD_HEAD.unpack_from(data, at)
    if opcode not in _KNOWN or opcode == 0 or length > MAX_RECORD_BYTES:
        return False
    end = at + RECORD_HEAD.size + length
    if end > len(data):
        own = _fields_length(data, at + RECORD_HEAD.size, opcode)
        return own is None or own == length
    return _record_issue(data, at, end, FileCheck(Path())) is None


class _Exact(io.BytesIO):
    """A record's bytes that refuse a read past their end.

    A length field flipped upwards inside a record (a string of a
    metadata record, say) would otherwise read to the record's end and
    parse: alone it fits, while a reader of the whole file reads on into
    the next records and fails there.
    """

    def read(self, size: int | None = -1, /) -> bytes:
        data = super().read(size)
        if size is not None and size >= 0 and len(data) < size:
            raise ValueError(
                f"a field of {size} bytes runs past its record's end"
            )
        return data


def _record_issue(
    data: bytes, at: int, end: int, result: FileCheck
) -> str | None:
    """Parse one record (chunks: decompressed, CRC checked); count its
    messages; the problem, if any."""
    try:
        stream = _Exact(data[at:end])
        reader = StreamReader(
            stream,
            skip_magic=True,
            emit_chunks=True,
            record_size_limit=MAX_RECORD_BYTES,
        )
        record = next(iter(reader.records))
        if stream.tell() != end - at:
            return "a record's fields do not fill its length"
        if isinstance(record, Chunk):
            # The inner length a reader trusts to allocate: it must be
            # what the record holds.
            field = at + RECORD_HEAD.size + 28
            field += 4 + len(record.compression.encode())
            (declared,) = struct.unpack_from("<Q", data, field)
            if declared != len(record.data):
                return (
                    f"a chunk declares {declared} bytes of records and "
                    f"holds {len(record.data)}"
                )
            inner = breakup_chunk(record, validate_crc=True)
            result.messages += sum(isinstance(r, Message) for r in inner)
        elif isinstance(record, Message):
            result.messages += 1
        elif isinstance(record, Attachment):
            # The writer fills its CRC (over the record after its head);
            # the reader skips it.
            (crc,) = struct.unpack_from("<I", data, end - 4)
            if (
                crc != 0
                and zlib.crc32(data[at + RECORD_HEAD.size : end - 4]) != crc
            ):
                return f"attachment {record.name!r} does not match its CRC"
        elif isinstance(record, Metadata) and not metadata_intact(
            record.name, record.metadata
        ):
            return f"metadata {record.name!r} does not match its CRC"
    except Exception as error:  # any parse failure is damage here
        return f"{type(error).__name__}: {error}"[:300]
    return None


def _index_issue(data: bytes) -> str | None:
    """What a reader of a finished file would meet through its summary.

    Readers find metadata and attachments through the summary's indexes,
    which a summary written without a CRC does not protect: each indexed
    record is read here as they would read it.
    """
    try:
        reader = make_reader(io.BytesIO(data))
        for _ in reader.iter_metadata():
            pass
        for _ in reader.iter_attachments():
            pass
    except Exception as error:  # any parse failure is damage here
        return f"the summary leads to no record: {type(error).__name__}"
    return None


def _summary_issue(data: bytes, footer_at: int) -> str | None:
    """Check the summary section against the footer's CRC."""
    body = footer_at + RECORD_HEAD.size
    summary_start, _offsets_start, crc = _FOOTER.unpack_from(data, body)
    if summary_start == 0 or crc == 0:
        return None  # no summary, or no CRC written
    if summary_start > footer_at:
        return f"the footer points past itself ({summary_start})"
    covered = data[summary_start : body + 16]
    if zlib.crc32(covered) != crc:
        return "the summary section does not match its CRC"
    return None


def check_folder(files: list[Path]) -> list[FileCheck]:
    """:func:`check_file` for each of ``files``."""
    return [check_file(path) for path in files]
