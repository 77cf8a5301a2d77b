"""Tests of state you can trust: damage in a journal is found, named and
never resumed; a crash's truncation still is."""

from __future__ import annotations

import random
import shutil
import subprocess
from typing import TYPE_CHECKING

import msgspec
import pytest

from fsw_scheduler.errors import InputError
from fsw_scheduler.journal.integrity import MAX_RECORD_BYTES, check_file
from fsw_scheduler.journal.state import StateDamaged, journal_files, open_state

from ..factories import DATA, cli_command

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    from fsw_scheduler.journal.state import FolderIdentity

    from ..conftest import Uninterrupted


@pytest.fixture
def state_folder(uninterrupted: Uninterrupted) -> Path:
    """A real node's state folder after the scripted session (shared:
    the tests copy it before they change anything)."""
    return uninterrupted.state


def _state(folder: Path) -> bytes:
    start = open_state(folder)
    assert start.rebuilt is not None
    return msgspec.json.encode(start.rebuilt.engine.snapshot())


def test_bit_flips_are_found_or_harmless(
    state_folder: Path, tmp_path: Path
) -> None:
    """Tests 400 single-bit flips across a finished journal: each is
    either refused, naming the file and the offset, or resumes exactly
    the original state; never another state, never a traceback."""
    (journal,) = journal_files(state_folder)
    original = journal.read_bytes()
    reference = _state(state_folder)
    rng = random.Random(21)
    refused = same = 0
    for index in range(400):
        folder = tmp_path / f"flip-{index}"
        folder.mkdir()
        damaged = bytearray(original)
        at = rng.randrange(len(damaged))
        damaged[at] ^= 1 << rng.randrange(8)
        (folder / journal.name).write_bytes(bytes(damaged))
        try:
            state = _state(folder)
        except StateDamaged as error:
            (check,) = error.damaged
            assert check.offset is not None and check.path.name == journal.name
            assert f"at byte {check.offset}" in str(error)
            refused += 1
        else:
            assert state == reference, (
                f"flip at byte {at} resumed another state"
            )
            same += 1
        shutil.rmtree(folder)
    assert refused > 300, (refused, same)


def test_truncation_is_not_damage(state_folder: Path, tmp_path: Path) -> None:
    """Tests a file cut short by a crash at many points: never called
    damaged; it is finished and resumed."""
    (journal,) = journal_files(state_folder)
    data = journal.read_bytes()
    for cut in range(64, len(data), max(1, len(data) // 40)):
        folder = tmp_path / f"cut-{cut}"
        folder.mkdir()
        (folder / journal.name).write_bytes(data[:cut])
        check = check_file(folder / journal.name)
        assert check.ok and not check.finished, (cut, check.describe())
        open_state(folder)  # finishes it; must not raise
        shutil.rmtree(folder)


def _records(data: bytes) -> list[tuple[int, int]]:
    """(offset, opcode) of each record of a journal's data section."""
    import struct

    at, found = 8, []
    while at + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, at)
        if opcode == 0x0F:  # data end: the summary follows
            break
        found.append((at, opcode))
        at += 9 + length
    return found


def test_a_length_flipped_past_the_end_of_a_crashed_file_is_damage(
    state_folder: Path, tmp_path: Path
) -> None:
    """Tests the journal a killed node leaves (every record up to its
    summary), with bits of each record's length field flipped in turn.

    A length flipped upwards past the end of the file once read as a
    record cut by the crash, so the records after it were dropped in
    silence and an older state resumed. Each flip is now refused."""
    (journal,) = journal_files(state_folder)
    data = journal.read_bytes()
    records = _records(data)
    assert len(records) > 10
    # The file as a kill leaves it: no data end, no summary, no footer.
    last_at = records[-1][0]
    length = int.from_bytes(data[last_at + 1 : last_at + 9], "little")
    crashed = data[: last_at + 9 + length]
    path = tmp_path / journal.name
    path.write_bytes(crashed)
    assert check_file(path).ok and not check_file(path).finished
    for at, _opcode in records:
        # Low bits (a length that stays inside the file), high ones (past
        # its end, under and over the record bound).
        for bit in (0, 3, 9, 14, 20, 27, 40, 63):
            flipped = bytearray(crashed)
            flipped[at + 1 + bit // 8] ^= 1 << (bit % 8)
            path.write_bytes(bytes(flipped))
            check = check_file(path)
            assert not check.ok, (at, bit, check.describe())
            # At the record, or where its wrong length leads.
            assert check.offset is not None and check.offset >= at
        with pytest.raises(StateDamaged):  # the last flip
            open_state(tmp_path)


def test_a_flipped_length_is_damage_not_an_allocation(tmp_path: Path) -> None:
    """Tests a record length field flipped to a huge value: named as
    damage before any allocation."""
    journal = sorted(DATA.parent.parent.glob("replay/paper.mcap"))[0]
    data = bytearray(journal.read_bytes())
    # The first record after the magic: its length field.
    data[9:17] = (MAX_RECORD_BYTES * 4).to_bytes(8, "little")
    path = tmp_path / "journal-0001.mcap"
    path.write_bytes(bytes(data))
    check = check_file(path)
    assert not check.ok and check.offset == 8, check.describe()


def test_run_refuses_a_damaged_folder_before_the_bus(
    state_folder: Path, tmp_path: Path
) -> None:
    """Tests ``run --state`` on a damaged folder: exit 2 naming the file
    and the offset, no traceback."""
    folder = tmp_path / "state"
    shutil.copytree(state_folder, folder)
    (journal,) = journal_files(folder)
    data = bytearray(journal.read_bytes())
    data[len(data) // 2] ^= 0xFF
    journal.write_bytes(bytes(data))
    result = subprocess.run(
        cli_command(
            "run",
            "--problem",
            str(DATA / "paper_table1.json"),
            "--state",
            str(folder),
            "--insecure",
            "--no-multicast-scouting",
            "--connect",
            "tcp/127.0.0.1:9",
        ),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2, result.stderr
    assert journal.name in result.stderr and "DAMAGED at byte" in result.stderr
    assert "Traceback" not in result.stderr


def _edit_info(src: Path, dst: Path, change: Callable[[dict], None]) -> None:
    """Copy a journal with its ``scheduler/config`` changed."""
    import json

    from .test_replay import Row, rewrite

    def edit(rows: list[Row]) -> list[Row]:
        out = []
        for row in rows:
            if row.topic.endswith("/scheduler/config"):
                doc = json.loads(row.data)
                change(doc)
                row = row._replace(data=json.dumps(doc).encode())
            out.append(row)
        return out

    rewrite(src, dst, edit)


def _identity(folder: Path) -> FolderIdentity:
    from fsw_scheduler.journal.state import FolderIdentity, problem_digest

    (journal,) = journal_files(folder)
    with open(journal, "rb") as f:
        from mcap.reader import make_reader

        for _s, channel, message in make_reader(f).iter_messages():
            if channel.topic.endswith("/scheduler/config"):
                from fsw_scheduler.wire.messages import NodeInfo

                info = msgspec.json.decode(message.data, type=NodeInfo)
                assert info.problem is not None
                return FolderIdentity(
                    info.spacecraft, problem_digest(info.problem)
                )
    raise AssertionError("no scheduler/config")


def test_another_sessions_journal_is_set_aside(
    state_folder: Path, tmp_path: Path
) -> None:
    """Tests a journal of the same spacecraft but another problem dropped
    in as the newest file: set aside in foreign/, the folder's own state
    resumed."""
    folder = tmp_path / "state"
    shutil.copytree(state_folder, folder)
    identity = _identity(folder)
    reference = _state(folder)
    (own,) = journal_files(folder)

    def other_problem(doc: dict) -> None:
        doc["problem"]["horizon"] += 1

    _edit_info(own, folder / "journal-0099.mcap", other_problem)
    start = open_state(folder, identity=identity)
    assert [p.parent.name for p in start.set_aside] == ["foreign"]
    assert start.rebuilt is not None
    assert msgspec.json.encode(start.rebuilt.engine.snapshot()) == reference


def test_a_newer_versions_journal_is_refused(
    state_folder: Path, tmp_path: Path
) -> None:
    """Tests a journal that says version 99.0.0: refused, naming it."""
    folder = tmp_path / "state"
    folder.mkdir()
    (own,) = journal_files(state_folder)
    _edit_info(own, folder / own.name, lambda d: d.update(version="99.0.0"))
    with pytest.raises(InputError, match=r"99\.0\.0"):
        open_state(folder)


def test_another_problem_needs_new_problem(
    state_folder: Path, tmp_path: Path
) -> None:
    """Tests a start with another --problem than the folder's: refused;
    with new_problem the old state is set aside and nothing resumed."""
    from fsw_scheduler.journal.state import FolderIdentity

    folder = tmp_path / "state"
    shutil.copytree(state_folder, folder)
    other = FolderIdentity("sat1", "0" * 64)
    with pytest.raises(InputError, match="--new-problem"):
        open_state(folder, identity=other)
    start = open_state(folder, identity=other, new_problem=True)
    assert start.rebuilt is None
    assert {p.parent.name for p in start.set_aside} == {"replaced"}
    assert journal_files(folder) == []


@pytest.mark.parametrize("kept", [0, 1, 4, 7])
def test_a_file_killed_as_it_opened_is_not_damage(
    state_folder: Path, tmp_path: Path, kept: int
) -> None:
    """Tests a newest journal file a writer was killed while opening
    (empty, or cut inside the MCAP magic): not damaged, and the folder
    resumes the same state as without it."""
    (journal,) = journal_files(state_folder)
    reference = _state(state_folder)
    folder = tmp_path / "state"
    shutil.copytree(state_folder, folder)
    newest = folder / journal.name.replace(".mcap", "-001.mcap")
    newest.write_bytes(journal.read_bytes()[:kept])
    check = check_file(newest)
    assert check.ok and not check.finished, check.describe()
    assert _state(folder) == reference


def test_a_flipped_magic_is_damage(tmp_path: Path) -> None:
    """Tests that a file whose magic is changed, not cut, is damage."""
    journal = sorted(DATA.parent.parent.glob("replay/paper.mcap"))[0]
    data = bytearray(journal.read_bytes())
    data[3] ^= 0x10
    path = tmp_path / "journal-0001.mcap"
    path.write_bytes(bytes(data))
    check = check_file(path)
    assert not check.ok and check.offset == 0, check.describe()


def test_a_length_flipped_past_its_record_is_damage(tmp_path: Path) -> None:
    """Tests a metadata record whose last value's length field grew past
    the record's end (one bit flip): the record alone would still parse,
    a reader of the whole file fails on it; it is damage at its offset."""
    import io

    from mcap.writer import Writer

    stream = io.BytesIO()
    writer = Writer(stream)
    writer.start()
    writer.add_metadata("settings", {"a": "yes", "b": "False"})
    writer.finish()
    data = bytearray(stream.getvalue())
    value = data.index(b"False")
    data[value - 2] ^= 0x10  # length 5 -> 1,048,581
    path = tmp_path / "flipped.mcap"
    path.write_bytes(bytes(data))
    check = check_file(path)
    assert check.damage is not None and "past its record" in check.damage
    assert check.offset is not None and check.offset < value


def test_a_flipped_setting_in_the_metadata_is_damage(
    state_folder: Path, tmp_path: Path
) -> None:
    """Tests the settings a resume reads from the journal's metadata (MCAP
    gives metadata records no CRC): one bit turning ``commit-window`` 0
    into 2 is damage at the record's offset, and the folder is refused,
    not resumed with other settings; readers never see the CRC key."""
    import io

    from mcap.writer import Writer

    from fsw_scheduler.journal.info import read_metadata
    from fsw_scheduler.journal.metadata import METADATA_CRC_KEY

    (journal,) = journal_files(state_folder)
    original = journal.read_bytes()
    metadata = read_metadata(journal)
    assert metadata and all(METADATA_CRC_KEY not in p for _, p in metadata)
    settings = dict(metadata)["fsw_scheduler.settings"]
    assert settings["commit-window"] == "0", settings
    key = original.index(b"commit-window")
    value = key + len(b"commit-window") + 4  # past the value's length
    assert original[value : value + 1] == b"0"
    damaged = bytearray(original)
    damaged[value] ^= 0b10  # "0" -> "2"
    folder = tmp_path / "flipped"
    folder.mkdir()
    (folder / journal.name).write_bytes(bytes(damaged))
    check = check_file(folder / journal.name)
    assert check.damage is not None and "CRC" in check.damage, check.describe()
    assert check.offset is not None and check.offset < key
    with pytest.raises(StateDamaged):
        open_state(folder)
    # A recording made before the CRC (none in its metadata) is intact.
    stream = io.BytesIO()
    writer = Writer(stream)
    writer.start()
    writer.add_metadata("settings", {"commit-window": "0"})
    writer.finish()
    old = tmp_path / "old.mcap"
    old.write_bytes(stream.getvalue())
    assert check_file(old).ok


def test_a_flipped_attachment_is_damage(
    state_folder: Path, tmp_path: Path
) -> None:
    """Tests a bit flipped inside an attachment (the session's problem):
    its CRC, which MCAP's reader skips, is checked, and it is damage."""
    (journal,) = journal_files(state_folder)
    original = journal.read_bytes()
    from fsw_scheduler.journal.info import read_attachments

    name, data = next(iter(read_attachments(journal).items()))
    inside = original.index(data) + len(data) // 2
    damaged = bytearray(original)
    damaged[inside] ^= 0b100
    path = tmp_path / journal.name
    path.write_bytes(bytes(damaged))
    check = check_file(path)
    assert check.damage is not None and name in check.damage, check.describe()
