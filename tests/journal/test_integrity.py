"""Tests of state you can trust: damage in a journal is found, named and
never resumed; a crash's truncation still is."""

from __future__ import annotations

import random
import shutil
import subprocess
from typing import TYPE_CHECKING

import msgspec
import pytest

from fsw_scheduler.journal.integrity import MAX_RECORD_BYTES, check_file
from fsw_scheduler.journal.state import StateDamaged, journal_files, open_state

from ..factories import DATA, cli_command
from .test_resume import soak_resume

if TYPE_CHECKING:
    from pathlib import Path


@pytest.fixture(scope="module")
def state_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A real node's state folder after the scripted session."""
    work = tmp_path_factory.mktemp("session")
    soak_resume().run_session(work, set(), random.Random(0))
    return work / "state"


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
