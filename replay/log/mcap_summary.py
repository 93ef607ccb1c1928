"""An MCAP file's footer and summary section, CRC-checked, and what they say compared with
the data section as scanned (:mod:`replay.log.mcap_scan`).

The summary repeats what the data holds (schemas, channels, one index entry per chunk and
per metadata record, message counts and times). A summary that disagrees with the data is
damage: a flipped bit in a channel's topic would drop a robot, a duplicated chunk index entry
would replay every frame twice. :func:`compare` lists every disagreement in words.
"""

from __future__ import annotations

import zlib
from collections import Counter
from dataclasses import dataclass, field
from typing import IO

from mcap.records import Channel, ChunkIndex, Footer, MetadataIndex, Schema, Statistics

from replay.log.mcap_records import (
    MAGIC,
    SUMMARY,
    Limits,
    Malformed,
    Op,
    parse_channel,
    parse_chunk_index,
    parse_footer,
    parse_metadata_index,
    parse_schema,
    parse_statistics,
    record_head,
    walk,
)
from replay.log.mcap_scan import DataScan

__all__ = ["FOOTER_BYTES", "Summary", "compare", "read_footer", "read_summary"]

FOOTER_BYTES = 9 + 20 + 8
"""Footer record (opcode, length, 20 bytes of fields) and the closing magic."""


@dataclass
class Summary:
    """The summary section's records."""

    offset: int
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)
    metadata_indexes: list[MetadataIndex] = field(default_factory=list)
    statistics: Statistics | None = None
    crc_checked: bool = False


def read_footer(f: IO[bytes], size: int) -> Footer:
    """The footer; raises :class:`Malformed` when the file does not end in one."""
    if size < 8 + FOOTER_BYTES:
        raise Malformed("the file is too short to end in a footer")
    f.seek(size - FOOTER_BYTES)
    tail = f.read(FOOTER_BYTES)
    if tail[-8:] != MAGIC:
        raise Malformed("the file does not end in the MCAP magic")
    op, length = record_head(tail)
    if op != Op.FOOTER or length != 20:
        raise Malformed("no footer record before the closing magic")
    return parse_footer(tail[9:29])


def read_summary(f: IO[bytes], size: int, footer: Footer, limits: Limits) -> Summary | None:
    """The summary section the footer points at (None when it has none), its CRC checked;
    raises :class:`Malformed`."""
    footer_pos = size - FOOTER_BYTES
    start = footer.summary_start
    if start == 0:
        return None
    if not 8 <= start <= footer_pos:
        raise Malformed(f"the footer's summary offset {start} is outside the file")
    if footer.summary_offset_start and not start <= footer.summary_offset_start <= footer_pos:
        raise Malformed(f"the footer's summary offset index {footer.summary_offset_start} "
                        "is outside the summary")
    if footer_pos - start > limits.max_chunk_bytes:
        raise Malformed(f"a summary of {footer_pos - start} bytes is over the limit of "
                        f"{limits.max_chunk_bytes} (--max-chunk-mib)")
    f.seek(start)
    data = f.read(footer_pos - start + 9 + 16)  # the summary and the footer up to its CRC
    summary = Summary(start)
    if footer.summary_crc != 0:
        if zlib.crc32(data) != footer.summary_crc:
            raise Malformed("summary CRC mismatch")
        summary.crc_checked = True
    _parse_records(data[:footer_pos - start], summary)
    return summary


def _parse_records(data: bytes, summary: Summary) -> None:
    for op, start, end in walk(data, SUMMARY, summary.offset):
        body = data[start:end]
        if op == Op.SCHEMA:
            s = parse_schema(body)
            summary.schemas[s.id] = s
        elif op == Op.CHANNEL:
            c = parse_channel(body)
            summary.channels[c.id] = c
        elif op == Op.CHUNK_INDEX:
            summary.chunk_indexes.append(parse_chunk_index(body))
        elif op == Op.METADATA_INDEX:
            summary.metadata_indexes.append(parse_metadata_index(body))
        elif op == Op.STATISTICS:
            summary.statistics = parse_statistics(body)


def compare(summary: Summary, scan: DataScan) -> list[str]:
    """Every way the summary disagrees with the data section (empty: they agree)."""
    problems = _compare_chunks(summary, scan)
    if summary.metadata_indexes:
        found = Counter(scan.metadata_records)
        listed = Counter((m.offset, m.length, m.name) for m in summary.metadata_indexes)
        if found != listed:
            problems.append("its metadata index does not match the metadata records "
                            f"({sum(listed.values())} listed, {sum(found.values())} found)")
    for kind, ours, theirs in (("channel", summary.channels, scan.channels),
                               ("schema", summary.schemas, scan.schemas)):
        for key in sorted(set(ours) & set(theirs)):
            if ours[key] != theirs[key]:
                problems.append(f"{kind} {key} differs from the data section's")
    stats = summary.statistics
    if stats is not None:
        if stats.chunk_count != len(scan.chunks):
            problems.append(f"its statistics count {stats.chunk_count} chunks, the data "
                            f"holds {len(scan.chunks)}")
        if stats.metadata_count != len(scan.metadata_records):
            problems.append(f"its statistics count {stats.metadata_count} metadata records, "
                            f"the data holds {len(scan.metadata_records)}")
        if stats.message_count and scan.blocks:
            start = min(b.start_ns for b in scan.blocks)
            end = max(b.end_ns for b in scan.blocks)
            if (stats.message_start_time, stats.message_end_time) != (start, end):
                problems.append("its statistics' time range differs from the data's")
    data_end = scan.data_end
    if data_end is not None and data_end + 13 != summary.offset:
        problems.append(f"the summary does not start after the data end record "
                        f"(byte {summary.offset}, expected {data_end + 13})")
    return problems


def _compare_chunks(summary: Summary, scan: DataScan) -> list[str]:
    if not summary.chunk_indexes:
        return []
    problems = []
    chunks = {c.offset: c for c in scan.chunks}
    listed = Counter(ci.chunk_start_offset for ci in summary.chunk_indexes)
    dup = sorted(o for o, n in listed.items() if n > 1)
    if dup:
        problems.append(f"its chunk index lists the chunk at byte {dup[0]} "
                        f"{listed[dup[0]]} times ({len(dup)} chunks listed more than once)")
    missing = sorted(set(chunks) - set(listed))
    if missing:
        problems.append(f"its chunk index has no entry for the chunk at byte {missing[0]} "
                        f"({len(missing)} chunks missing)")
    extra = sorted(set(listed) - set(chunks))
    if extra:
        problems.append(f"its chunk index lists a chunk at byte {extra[0]} that the data "
                        f"does not hold ({len(extra)} such entries)")
    for ci in summary.chunk_indexes:
        c = chunks.get(ci.chunk_start_offset)
        if c is None:
            continue
        if ((ci.message_start_time, ci.message_end_time, ci.chunk_length, ci.compression,
             ci.uncompressed_size, ci.compressed_size)
                != (c.message_start_time, c.message_end_time, c.length, c.compression,
                    c.uncompressed_size, c.data_length)):
            problems.append(f"its chunk index entry for the chunk at byte {c.offset} "
                            "disagrees with the chunk (time range, size or compression)")
            break
    return problems
