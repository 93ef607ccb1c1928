"""replay.log.mcap_summary: the footer, the CRC-checked summary, and every way it can
disagree with the data section."""

from __future__ import annotations

import copy
import io
from pathlib import Path

import pytest
from fuzzing import GOLDEN, read_raw, write_raw
from mcap.writer import CompressionType

from replay.log.mcap_records import Limits, Malformed
from replay.log.mcap_scan import DataScan, scan_data
from replay.log.mcap_summary import FOOTER_BYTES, Summary, compare, read_footer, read_summary

LIMITS = Limits()


@pytest.fixture(scope="module")
def log() -> bytes:
    return write_raw(read_raw(GOLDEN / "scenario2.mcap"), compression=CompressionType.LZ4,
                     chunk_size=32 * 1024)


def _read(log: bytes) -> tuple[Summary, DataScan]:
    f = io.BytesIO(log)
    summary = read_summary(f, len(log), read_footer(f, len(log)), LIMITS)
    assert summary is not None
    return summary, scan_data(f, Path("s.mcap"), len(log), LIMITS, recover=False)


def test_an_intact_summary_agrees_with_the_data(log: bytes) -> None:
    summary, scan = _read(log)
    assert summary.crc_checked and len(summary.chunk_indexes) == len(scan.chunks) > 3
    assert summary.statistics is not None
    assert summary.statistics.message_count > 0 and summary.metadata_indexes
    assert compare(summary, scan) == []


def test_each_disagreement_is_named(log: bytes) -> None:
    """Guards every comparison: each edit of the summary is reported in its own words."""
    summary, scan = _read(log)

    def edited(edit: object) -> list[str]:
        s = copy.deepcopy(summary)
        edit(s)  # type: ignore[operator]
        return compare(s, scan)

    first = summary.chunk_indexes[0]
    assert edited(lambda s: s.chunk_indexes.append(first))[0].startswith(
        f"its chunk index lists the chunk at byte {first.chunk_start_offset} 2 times")
    assert edited(lambda s: s.chunk_indexes.pop(0))[0].startswith(
        f"its chunk index has no entry for the chunk at byte {first.chunk_start_offset}")

    def shift(s: Summary) -> None:
        s.chunk_indexes[0].chunk_start_offset += 1

    assert any("lists a chunk at byte" in p for p in edited(shift))

    def late(s: Summary) -> None:
        s.chunk_indexes[1].message_end_time += 1

    assert edited(late) == [f"its chunk index entry for the chunk at byte "
                            f"{summary.chunk_indexes[1].chunk_start_offset} disagrees with the "
                            "chunk (time range, size or compression)"]
    assert edited(lambda s: s.metadata_indexes.pop())[0].startswith(
        "its metadata index does not match the metadata records")
    def stats(s: Summary) -> None:
        assert s.statistics is not None
        s.statistics.chunk_count += 1
        s.statistics.metadata_count += 1
        s.statistics.message_start_time += 1

    assert edited(stats) == [
        f"its statistics count {len(scan.chunks) + 1} chunks, the data holds "
        f"{len(scan.chunks)}",
        f"its statistics count {len(scan.metadata_records) + 1} metadata records, the data "
        f"holds {len(scan.metadata_records)}",
        "its statistics' time range differs from the data's"]

    def moved(s: Summary) -> None:
        s.offset += 1

    assert scan.data_end is not None
    assert edited(moved) == [f"the summary does not start after the data end record (byte "
                             f"{summary.offset + 1}, expected {scan.data_end + 13})"]


def test_a_channel_or_schema_differing_from_the_data_is_named() -> None:
    """Unchunked, the data section defines channels and schemas outside chunks, where the
    scan compares them with the summary's."""
    summary, scan = _read(write_raw(read_raw(GOLDEN / "scenario2.mcap"), use_chunking=False))
    cid, sid = min(scan.channels), min(scan.schemas)
    assert compare(summary, scan) == []
    summary.channels[cid].topic += "x"
    summary.schemas[sid].data += b"\n"
    assert compare(summary, scan) == [f"channel {cid} differs from the data section's",
                                      f"schema {sid} differs from the data section's"]


def test_the_summary_crc_covers_the_summary(log: bytes) -> None:
    f = io.BytesIO(log)
    footer = read_footer(f, len(log))
    bad = bytearray(log)
    bad[footer.summary_start + 20] ^= 1
    with pytest.raises(Malformed, match="summary CRC mismatch"):
        read_summary(io.BytesIO(bytes(bad)), len(bad), footer, LIMITS)


def test_footer_offsets_outside_the_file_are_refused(log: bytes) -> None:
    footer = read_footer(io.BytesIO(log), len(log))
    for start, index, words in ((len(log), 0, "summary offset"),
                                (footer.summary_start, len(log), "summary offset index")):
        bad = copy.copy(footer)
        bad.summary_start, bad.summary_offset_start = start, index
        with pytest.raises(Malformed, match=f"the footer's {words} .* outside"):
            read_summary(io.BytesIO(log), len(log), bad, LIMITS)
    with pytest.raises(Malformed, match="over the limit"):
        read_summary(io.BytesIO(log), len(log), footer, Limits(max_chunk_bytes=100))
    empty = copy.copy(footer)
    empty.summary_start = 0
    assert read_summary(io.BytesIO(log), len(log), empty, LIMITS) is None
    with pytest.raises(Malformed, match="does not end in the MCAP magic"):
        read_footer(io.BytesIO(log[:-1]), len(log) - 1)
    with pytest.raises(Malformed, match="too short"):
        read_footer(io.BytesIO(log[:FOOTER_BYTES]), FOOTER_BYTES)
