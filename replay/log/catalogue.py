"""What an MCAP file holds, checked: the data section scanned, the footer and summary read and
compared with it, and (when asked, or when only the chunks name the channels) every chunk
decompressed and CRC-checked.

:func:`build_catalogue` is shared by the reader (:mod:`replay.log.reader`) and ``dsp-info``.
Strict: any damage raises a :class:`~replay.errors.ReplayError` naming the file and byte.
``recover=True``: damage is collected (:attr:`Catalogue.damage`, :attr:`Catalogue.problems`)
and the readable rest is catalogued.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from mcap.records import Channel, Footer, Message, Schema

from replay.errors import CorruptLogError, InputNotFoundError, NotMcapError, TruncatedLogError
from replay.log.mcap_chunks import CUT, Salvage, decompress, salvage
from replay.log.mcap_records import (
    MAGIC,
    RUN,
    ChunkHeader,
    Limits,
    Malformed,
    Op,
    chunk_records,
    parse_message,
    walk,
)
from replay.log.mcap_scan import Block, Damage, DataScan, scan_data
from replay.log.mcap_summary import Summary, compare, read_footer, read_summary
from replay.log.recovery import SalvagedChunk

__all__ = [
    "Catalogue",
    "build_catalogue",
    "check_definition",
    "check_mcap_file",
    "load_block",
    "nothing_recovered",
    "read_all_blocks",
]

Record = Schema | Channel | Message


def check_mcap_file(path: Path) -> int:
    """The size of the MCAP file at ``path``; raises :class:`InputNotFoundError` when it is
    not a file and :class:`NotMcapError` when it does not start with the MCAP magic."""
    if not path.is_file():
        raise InputNotFoundError(path)
    with path.open("rb") as f:
        head = f.read(len(MAGIC))
    if head != MAGIC:
        raise NotMcapError(path)
    return path.stat().st_size


@dataclass
class Catalogue:
    """A log's layout and contents, as far as they could be read."""

    path: Path
    size: int
    scan: DataScan
    footer: Footer | None = None
    summary: Summary | None = None
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    counts: dict[int, int] | None = None
    """Messages per channel id: counted when every chunk was read, else the statistics'."""
    problems: list[str] = field(default_factory=list)
    """Integrity problems that did not stop reading (recover mode)."""
    damage: list[Damage] = field(default_factory=list)
    """Stretches of the file lost (recover mode)."""
    bad_blocks: set[int] = field(default_factory=set)
    """Offsets of blocks that do not load (recover mode)."""
    salvaged: list[SalvagedChunk] = field(default_factory=list)
    """What was kept of each cut or damaged chunk (recover mode)."""
    salvaged_blocks: list[Block] = field(default_factory=list)
    """The blocks of those that kept a message."""
    chunks_checked: bool = False

    @property
    def blocks(self) -> list[Block]:
        whole = [b for b in self.scan.blocks if b.offset not in self.bad_blocks]
        return sorted(whole + self.salvaged_blocks, key=lambda b: b.offset)

    @property
    def metadata(self) -> dict[str, dict[str, str]]:
        return self.scan.metadata


def _fail(cat: Catalogue, recover: bool, problem: str) -> None:
    if not recover:
        raise CorruptLogError(cat.path, problem)
    cat.problems.append(problem)


def build_catalogue(f: IO[bytes], path: Path, size: int, limits: Limits, *, recover: bool,
                    read_chunks: bool = False, validate_crcs: bool = True) -> Catalogue:
    """Catalogue the open log ``f``. ``read_chunks``: decompress and check every chunk even
    when the summary names every channel (always done with ``recover`` or no summary)."""
    footer: Footer | None = None
    summary: Summary | None = None
    footer_problem = ""
    try:
        footer = read_footer(f, size)
    except Malformed as err:
        if not recover:
            raise TruncatedLogError(path, str(err)) from err
        footer_problem = f"no footer: {err}"
    scan = scan_data(f, path, size, limits, recover=recover)
    cat = Catalogue(path, size, scan, footer)
    if footer_problem:
        cat.problems.append(footer_problem)
    if footer is not None:
        try:
            summary = read_summary(f, size, footer, limits)
        except Malformed as err:
            _fail(cat, recover, f"summary: {err}")
    if scan.data_crc_ok is False:
        _fail(cat, recover, "data section CRC mismatch")
    if summary is not None and footer is not None:
        problems = compare(summary, scan)
        if problems:
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            _fail(cat, recover, f"the summary disagrees with the data: {problems[0]}{more}")
            if recover:  # the data, as scanned, is what is read
                cat.problems[-1:] = [f"the summary disagrees with the data: {p}"
                                     for p in problems]
                summary = None
    cat.summary = summary
    if summary is not None:
        cat.schemas.update(summary.schemas)
        cat.channels.update(summary.channels)
        if summary.statistics is not None:
            cat.counts = dict(summary.statistics.channel_message_counts)
    cat.schemas.update(scan.schemas)
    cat.channels.update(scan.channels)
    cat.damage.extend(scan.damage)
    if recover or summary is None or read_chunks or (scan.chunks and not summary.channels):
        read_all_blocks(f, cat, limits, recover=recover, validate_crcs=validate_crcs)
    return cat


def read_all_blocks(f: IO[bytes], cat: Catalogue, limits: Limits, *, recover: bool,
                    validate_crcs: bool) -> None:
    """Decompress every block: schemas and channels the chunks define, message counts, CRCs.
    ``recover``: a block that does not load is damage, and what precedes the damage in a
    chunk (or the cut, in the chunk the end of the file cuts) is salvaged."""
    counts: dict[int, int] = {}
    for block in cat.scan.blocks:
        try:
            _add(cat, load_block(f, block, limits, validate_crcs=validate_crcs), block, counts)
        except (Malformed, CorruptLogError) as err:
            where = f"chunk at byte {block.offset}" if block.chunk else (
                f"messages at byte {block.offset}")
            if not recover:
                raise CorruptLogError(cat.path, f"{where}: {err}") from err
            cat.bad_blocks.add(block.offset)
            lost = Damage(block.offset, block.length, f"{where}: {err}", block.start_ns,
                          block.end_ns, block.messages, chunks=1 if block.chunk else 0)
            if block.chunk is not None and isinstance(err, Malformed):
                lost = _salvage(f, cat, block.chunk, lost, limits, counts,
                                validate_crcs=validate_crcs)
            cat.damage.append(lost)
    cut = cat.scan.cut_chunk
    if recover and cut is not None:
        for i, d in enumerate(cat.damage):
            if d.offset == cut.offset:
                cat.damage[i] = _salvage(f, cat, cut, d, limits, counts,
                                         validate_crcs=validate_crcs)
    stats = cat.summary.statistics if cat.summary is not None else None
    if stats is not None and not cat.bad_blocks and not cat.salvaged:
        wanted = {k: v for k, v in stats.channel_message_counts.items() if v}
        found = {k: v for k, v in counts.items() if v}
        if (wanted and wanted != found) or stats.message_count != sum(counts.values()):
            _fail(cat, recover, "the summary disagrees with the data: its statistics count "
                  f"{stats.message_count} messages, the chunks hold {sum(counts.values())}")
    cat.counts = counts
    cat.chunks_checked = True


def _add(cat: Catalogue, records: list[Record], block: Block, counts: dict[int, int]) -> None:
    """Count a block's messages and check its definitions (nothing counted if one fails)."""
    mine: dict[int, int] = {}
    for rec in records:
        if isinstance(rec, Message):
            mine[rec.channel_id] = mine.get(rec.channel_id, 0) + 1
        else:
            check_definition(cat, rec, block)
    for cid, n in mine.items():
        counts[cid] = counts.get(cid, 0) + n


def _salvage(f: IO[bytes], cat: Catalogue, chunk: ChunkHeader, lost: Damage, limits: Limits,
             counts: dict[int, int], *, validate_crcs: bool) -> Damage:
    """Salvage the chunk whose loss is ``lost``; returns what is lost after all."""
    kept = _salvage_records(f, chunk, limits, validate_crcs=validate_crcs)
    msgs = kept.messages
    block = Block(chunk.offset, min(chunk.length, cat.size - chunk.offset),
                  min((m.log_time for m in msgs), default=chunk.message_start_time),
                  max((m.log_time for m in msgs), default=chunk.message_start_time),
                  chunk, len(msgs), salvage=True)
    try:
        _add(cat, kept.records, block, counts)
    except CorruptLogError as err:
        kept, msgs = Salvage([], kept.decoded_bytes, str(err)), []
    cat.salvaged.append(SalvagedChunk(
        chunk.offset, len(msgs), block.start_ns if msgs else None,
        block.end_ns if msgs else None, kept.decoded_bytes, chunk.uncompressed_size,
        kept.reason))
    if not msgs:
        return lost
    cat.salvaged_blocks.append(block)
    return dataclasses.replace(  # lost: what follows the last message kept
        lost, start_ns=block.end_ns,
        messages=None if lost.messages is None else max(0, lost.messages - len(msgs)))


def _salvage_records(f: IO[bytes], chunk: ChunkHeader, limits: Limits, *,
                     validate_crcs: bool) -> Salvage:
    if chunk.data_length > limits.max_chunk_bytes:
        return Salvage([], 0, f"{chunk.data_length} bytes of chunk data, over the limit of "
                       f"{limits.max_chunk_bytes} (--max-chunk-mib)")
    f.seek(chunk.data_offset)
    data = f.read(chunk.data_length)
    if not validate_crcs:
        chunk = dataclasses.replace(chunk, uncompressed_crc=0)
    return salvage(chunk, data, limits, cut=len(data) < chunk.data_length)


def nothing_recovered(cat: Catalogue) -> str:
    """Why ``--recover`` found no message, in terms of the log."""
    chunks = [b for b in cat.scan.blocks if b.chunk is not None]
    cut = cat.scan.cut_chunk
    tried = {s.offset: s for s in cat.salvaged}
    if cut is not None and not chunks:
        kept = tried.get(cut.offset)
        why = "it could not be read" if kept is None else (
            f"{kept.decoded_bytes} of its {kept.uncompressed_bytes} bytes decode, no whole "
            "message among them" if kept.reason == CUT else kept.reason)
        return (f"its only chunk (at byte {cut.offset}) is cut at byte {cat.size}; nothing "
                f"before the cut decodes ({why})")
    if chunks and len(cat.bad_blocks) >= len(chunks):
        first = chunks[0].offset
        why = tried[first].reason if first in tried else "it does not decode"
        return (f"{'its only chunk' if len(chunks) == 1 else f'all {len(chunks)} chunks'} "
                f"{'is' if len(chunks) == 1 else 'are'} damaged (the first at byte {first}: "
                f"{why})")
    if cat.damage:
        d = cat.damage[0]
        return f"no message before the damage at byte {d.offset} ({d.reason})"
    return "the log holds no message"


def check_definition(cat: Catalogue, rec: Schema | Channel, block: Block) -> None:
    """A schema or channel a block defines: new ones join the catalogue; one that differs
    from the catalogue's raises :class:`CorruptLogError` (the summary or data is damaged)."""
    table: dict[int, Schema] | dict[int, Channel]
    table, kind = (cat.schemas, "schema") if isinstance(rec, Schema) else (
        cat.channels, "channel")
    known = table.get(rec.id)
    if known is None:
        if kind == "channel" and cat.summary is not None and cat.summary.channels:
            raise CorruptLogError(cat.path, "the summary disagrees with the data: it lacks "
                                  f"channel {rec.id}, which the block at byte {block.offset} "
                                  "defines")
        table[rec.id] = rec  # type: ignore[assignment]
    elif known != rec:
        raise CorruptLogError(cat.path, "the summary disagrees with the data: the block at "
                              f"byte {block.offset} defines {kind} {rec.id} differently")


def load_block(f: IO[bytes], block: Block, limits: Limits, *,
               validate_crcs: bool = True) -> list[Record]:
    """The records of a block (a chunk, the salvaged part of one, or a run of messages
    outside chunks), in file order; raises :class:`Malformed`."""
    if block.chunk is not None and block.salvage:
        return _salvage_records(f, block.chunk, limits, validate_crcs=validate_crcs).records
    if block.chunk is not None:
        chunk: ChunkHeader = block.chunk
        if chunk.data_length > limits.max_chunk_bytes:
            raise Malformed(f"{chunk.data_length} bytes of chunk data, over the limit of "
                            f"{limits.max_chunk_bytes} (--max-chunk-mib)")
        f.seek(chunk.data_offset)
        data = f.read(chunk.data_length)
        if len(data) != chunk.data_length:
            raise Malformed("the chunk is cut short")
        if not validate_crcs:
            chunk = dataclasses.replace(chunk, uncompressed_crc=0)
        raw = decompress(chunk, data, limits)
        del data
        records = list(chunk_records(raw, limits))
        times = [r.log_time for r in records if isinstance(r, Message)]
        if times and (min(times) < chunk.message_start_time
                      or max(times) > chunk.message_end_time):
            raise Malformed("messages outside the time range the chunk header declares")
        return records
    f.seek(block.offset)
    data = f.read(block.length)
    return [parse_message(data, start, end)
            for op, start, end in walk(data, RUN, block.offset) if op == Op.MESSAGE]
