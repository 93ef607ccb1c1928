"""replay.log.mcap_scan: one pass over the data section, what it finds, and the resync of
``--recover`` after damage."""

from __future__ import annotations

import io
import struct
from pathlib import Path

import pytest
from fuzzing import GOLDEN, read_raw, records, write_raw
from mcap.writer import CompressionType

from replay.errors import CorruptLogError
from replay.log.mcap_records import MAGIC, Limits, Op
from replay.log.mcap_scan import DataScan, scan_data

LIMITS = Limits()


def scan(data: bytes, *, recover: bool = False) -> DataScan:
    return scan_data(io.BytesIO(data), Path("s.mcap"), len(data), LIMITS, recover=recover)


@pytest.fixture(scope="module")
def chunked() -> bytes:
    return write_raw(read_raw(GOLDEN / "rolling.mcap"), compression=CompressionType.ZSTD,
                     chunk_size=64 * 1024)


def test_the_scan_finds_every_chunk_and_metadata_record(chunked: bytes) -> None:
    found = scan(chunked)
    recs = records(chunked)
    assert [c.offset for c in found.chunks] == [r.offset for r in recs if r.op == Op.CHUNK]
    assert [m[0] for m in found.metadata_records] == [r.offset for r in recs
                                                      if r.op == Op.METADATA]
    assert set(found.metadata) == {"dsp.scenario", "dsp.cameras", "dsp.recorder"}
    assert found.profile == "ros2" and found.data_crc_ok in (None, True)
    # each chunk's messages counted from its message index records
    assert sum(b.messages or 0 for b in found.blocks) == 76
    assert not found.damage and not found.truncated and found.cut_chunk is None


def test_a_damaged_chunk_header_is_skipped_to_the_next_chunk(chunked: bytes) -> None:
    """Guards the resync: a chunk whose compression name is garbage is damage from its
    offset to the next intact chunk record, which the scan reads on from."""
    chunks = [r for r in records(chunked) if r.op == Op.CHUNK]
    victim, after = chunks[2], chunks[3]
    bad = bytearray(chunked)
    bad[victim.offset + 9 + 32:victim.offset + 9 + 36] = b"\xff\xfe\xfd\xfc"
    with pytest.raises(CorruptLogError, match=f"byte {victim.offset}: chunk"):
        scan(bytes(bad))
    found = scan(bytes(bad), recover=True)
    [d] = found.damage
    assert (d.offset, d.offset + d.length, d.chunks) == (victim.offset, after.offset, 1)
    assert [c.offset for c in found.chunks] == [c.offset for c in chunks if c is not victim]


def test_the_chunk_a_cut_falls_in_is_kept_for_salvage(chunked: bytes) -> None:
    chunks = [r for r in records(chunked) if r.op == Op.CHUNK]
    victim = chunks[1]
    cut = chunked[:victim.offset + 9 + victim.length // 2]
    found = scan(cut, recover=True)
    assert found.truncated and found.cut_chunk is not None
    assert found.cut_chunk.offset == victim.offset
    assert found.cut_chunk.data_offset + found.cut_chunk.data_length == (
        victim.offset + 9 + victim.length)
    assert found.damage[0].start_ns == found.cut_chunk.message_start_time
    # cut inside its header: no salvage, the damage is still named at the chunk
    early = scan(chunked[:victim.offset + 9 + 20], recover=True)
    assert early.cut_chunk is None and early.damage[0].offset == victim.offset


def _message(t: int) -> bytes:
    body = struct.pack("<HIQQ", 1, 0, t, t) + b"data"
    return struct.pack("<BQ", Op.MESSAGE, len(body)) + body


def test_a_run_of_messages_ends_at_any_other_record() -> None:
    """Messages outside chunks load as runs; a record between them (here a message index,
    which no reader needs there) ends the run, so a run's bytes are its messages only."""
    index = struct.pack("<BQ", Op.MESSAGE_INDEX, 6) + struct.pack("<HI", 1, 0)
    head = MAGIC + struct.pack("<BQ", Op.HEADER, 8) + struct.pack("<II", 0, 0)
    data = (head + _message(1) + _message(2) + index + _message(3)
            + struct.pack("<BQ", Op.DATA_END, 4) + bytes(4))
    found = scan(data)
    assert [(b.offset, b.messages, b.start_ns, b.end_ns) for b in found.blocks] == [
        (len(head), 2, 1, 2), (len(head) + 2 * 35 + len(index), 1, 3, 3)]
    assert sum(b.length for b in found.blocks) == 3 * 35


def test_a_damaged_header_costs_only_the_profile() -> None:
    head = MAGIC + struct.pack("<BQ", Op.HEADER, 4) + struct.pack("<I", 100)
    data = head + _message(1) + struct.pack("<BQ", Op.DATA_END, 4) + bytes(4)
    found = scan(data)
    assert found.profile is None and [b.messages for b in found.blocks] == [1]
