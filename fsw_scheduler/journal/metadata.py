"""Metadata records with a CRC of their own.

MCAP covers chunks (messages, schemas, channels) and a finished file's
summary by CRCs, not metadata records: a bit flip in the settings a
resume reads from them would pass unseen. The writer adds one key,
:data:`METADATA_CRC_KEY`, to each record it writes; the integrity walk
(:mod:`fsw_scheduler.journal.integrity`) checks it, and readers
(:func:`fsw_scheduler.journal.info.read_metadata`) drop it.
"""

from __future__ import annotations

import json
import zlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Mapping

#: The key of a metadata record's own CRC (:func:`metadata_crc`). MCAP
#: covers chunks and the summary by CRCs, not metadata records: a bit
#: flip in the settings the node resumes with would pass unseen.
METADATA_CRC_KEY = "_crc32"


def metadata_crc(name: str, pairs: Mapping[str, str]) -> str:
    """The CRC-32 of a metadata record's name and pairs (without
    :data:`METADATA_CRC_KEY`), as 8 hex digits; the order of the pairs
    does not count."""
    body = [
        name,
        sorted((k, v) for k, v in pairs.items() if k != METADATA_CRC_KEY),
    ]
    text = json.dumps(body, ensure_ascii=False, separators=(",", ":"))
    return f"{zlib.crc32(text.encode()):08x}"


def metadata_intact(name: str, pairs: Mapping[str, str]) -> bool:
    """False when a metadata record carries a CRC its contents do not
    match (records written before there was one carry none: True)."""
    crc = pairs.get(METADATA_CRC_KEY)
    return crc is None or crc == metadata_crc(name, pairs)
