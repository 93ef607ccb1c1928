"""replay.log.mcap_scan: one pass over the data section, what it finds, and the resync of
``--recover`` after damage."""

from __future__ import annotations

import io
import struct
from pathlib import Path
from typing import Any

import pytest
from fuzzing import GOLDEN, read_raw, records, write_raw
from mcap.writer import CompressionType

from replay.errors import CorruptLogError
from replay.log.mcap_records import (
    CHUNK,
    FILE,
    MAGIC,
    RUN,
    SUMMARY,
    Cut,
    FileBytes,
    Limits,
    Malformed,
    Op,
    walk,
)
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


def test_the_scan_walks_the_file_with_the_one_record_iterator(
        chunked: bytes, monkeypatch: pytest.MonkeyPatch) -> None:
    """The scan, the summary and the catalogue's chunks and runs all go through
    ``mcap_records.walk``: a fault planted in that one iterator shows in every one of them."""
    import replay.log.catalogue as catalogue_mod
    import replay.log.mcap_records as records_mod
    import replay.log.mcap_scan as scan_mod
    import replay.log.mcap_summary as summary_mod
    from replay.log.catalogue import build_catalogue, load_block

    real = records_mod.walk
    seen: list[str] = []

    def spy(buf: Any, region: Any, base: int = 0, start: int = 0) -> Any:
        seen.append(region.past_end)
        return real(buf, region, base, start)

    for mod in (records_mod, scan_mod, summary_mod, catalogue_mod):
        monkeypatch.setattr(mod, "walk", spy)
    unchunked = write_raw(read_raw(GOLDEN / "rolling.mcap"), use_chunking=False)
    for log in (chunked, unchunked):
        f = io.BytesIO(log)
        cat = build_catalogue(f, Path("w.mcap"), len(log), LIMITS, recover=False)
        for block in cat.blocks:
            load_block(f, block, LIMITS)
    assert {FILE.past_end, SUMMARY.past_end, CHUNK.past_end, RUN.past_end} <= set(seen)


def test_the_file_walk_says_where_the_log_ends() -> None:
    """The data section walked in the file: a record the end cuts is :class:`Cut` with its
    opcode, length and offset (what salvage needs); opcode 0 is damage, not a cut."""
    body = b"x" * 40
    data = MAGIC + bytes((Op.METADATA,)) + struct.pack("<Q", len(body)) + body
    view = FileBytes(io.BytesIO(data), len(data))
    assert len(view) == len(data) and view[8:9] == bytes((Op.METADATA,))
    assert list(walk(view, FILE, start=8)) == list(walk(data, FILE, start=8)) == [
        (Op.METADATA, 17, 57)]
    cut = FileBytes(io.BytesIO(data[:50]), 50)
    with pytest.raises(Cut) as raised:
        list(walk(cut, FILE, start=8))
    err = raised.value
    assert (err.at, err.op, err.length) == (8, Op.METADATA, 40)
    assert str(err) == "a metadata of 40 bytes runs past the end of the file (50 bytes)"
    for n in range(1, 9):  # 1 to 8 of a record head's 9 bytes
        with pytest.raises(Cut, match="the log ends inside a record header"):
            list(walk(FileBytes(io.BytesIO(data[:8 + n]), 8 + n), FILE, start=8))
    zero = MAGIC + bytes(9) + b"\xff" * 2 ** 10
    with pytest.raises(Malformed, match="a record with opcode 0") as raised:
        list(walk(zero, FILE, start=8))
    assert not isinstance(raised.value, Cut) and raised.value.at == 8


def test_damage_with_opcode_0_is_resynced_past_even_when_its_length_runs_off(
        chunked: bytes) -> None:
    """Guards the order of the checks: garbage whose first byte is 0 and whose length runs
    past the file is damage the scan reads on from, not the end of the log."""
    chunks = [r for r in records(chunked) if r.op == Op.CHUNK]
    victim, after = chunks[1], chunks[2]
    bad = bytearray(chunked)
    bad[victim.offset:victim.offset + 9] = b"\x00" + b"\xff" * 8
    found = scan(bytes(bad), recover=True)
    [d] = found.damage
    assert (d.offset, d.offset + d.length) == (victim.offset, after.offset)
    assert not found.truncated and found.data_end is not None


def test_the_codec_names_opcodes_not_bytes() -> None:
    """The record codec speaks mcap's ``Opcode``: no opcode written as a byte literal, and
    a record's head parsed in one place (``mcap_records``)."""
    import re

    root = Path(scan_data.__code__.co_filename).parent
    for name in ("mcap_records", "mcap_scan", "mcap_summary", "mcap_chunks", "catalogue",
                 "reader", "recovery"):
        text = (root / f"{name}.py").read_text()
        assert not re.search(r"\b0x[0-9a-fA-F]{1,2}\b", text), name
        assert text.count('"<BQ"') == (1 if name == "mcap_records" else 0), name


@pytest.mark.parametrize("short", [1, 5, 9])
def test_a_resync_never_takes_a_chunk_that_runs_past_the_end(chunked: bytes,
                                                             short: int) -> None:
    """Guards the resync's bound: after damage, a chunk record whose declared length runs
    ``short`` bytes (up to its 9-byte head) past the end of a cut file is not taken: the
    damage runs to the end."""
    chunks = [r for r in records(chunked) if r.op == Op.CHUNK]
    victim, after = chunks[1], chunks[2]
    bad = bytearray(chunked)
    bad[victim.offset + 9:victim.offset + 9 + 32] = b"\xff" * 32  # its header unreadable
    cut = bytes(bad[:after.offset + 9 + after.length - short])  # its length is the body's
    found = scan(cut, recover=True)
    [d] = found.damage  # one damage, from the victim to the end: nothing resynced on
    assert (d.offset, d.offset + d.length) == (victim.offset, len(cut))
    assert found.truncated and found.cut_chunk is None
    assert after.offset not in [c.offset for c in found.chunks]
