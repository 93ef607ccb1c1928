"""What an MCAP file holds, checked: the data section scanned, the footer and summary read and
compared with it, and (when asked, or when only the chunks name the channels) every chunk
decompressed and CRC-checked.

:func:`build_catalogue` is shared by the reader (:mod:`replay.log.reader`) and ``dsp-info``.
Strict: any damage raises a :class:`~replay.errors.ReplayError` naming the file and byte.
``recover=True``: damage is collected (:attr:`Catalogue.damage`, :attr:`Catalogue.problems`)
and the readable rest is catalogued.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from mcap.records import Channel, Message, Schema

from replay.errors import CorruptLogError, InputNotFoundError, NotMcapError, TruncatedLogError
from replay.log.mcap_records import (
    MAGIC,
    ChunkHeader,
    Footer,
    Limits,
    Malformed,
    chunk_records,
    decompress,
    parse_message,
)
from replay.log.mcap_scan import Block, Damage, DataScan, scan_data
from replay.log.mcap_summary import Summary, compare, read_footer, read_summary

__all__ = [
    "Catalogue",
    "build_catalogue",
    "check_definition",
    "check_mcap_file",
    "load_block",
    "read_all_blocks",
]


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
    chunks_checked: bool = False

    @property
    def blocks(self) -> list[Block]:
        return [b for b in self.scan.blocks if b.offset not in self.bad_blocks]

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
        problems = compare(summary, scan, footer, size)
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
    """Decompress every block: schemas and channels the chunks define, message counts, CRCs."""
    counts: dict[int, int] = {}
    for block in cat.scan.blocks:
        try:
            records = load_block(f, block, limits, validate_crcs=validate_crcs)
            for rec in records:
                if isinstance(rec, Message):
                    counts[rec.channel_id] = counts.get(rec.channel_id, 0) + 1
                else:
                    check_definition(cat, rec, block)
        except (Malformed, CorruptLogError) as err:
            where = f"chunk at byte {block.offset}" if block.chunk else (
                f"messages at byte {block.offset}")
            if not recover:
                raise CorruptLogError(cat.path, f"{where}: {err}") from err
            cat.bad_blocks.add(block.offset)
            cat.damage.append(Damage(block.offset, block.length, f"{where}: {err}",
                                     block.start_ns, block.end_ns, block.messages,
                                     chunks=1 if block.chunk else 0))
    stats = cat.summary.statistics if cat.summary is not None else None
    if stats is not None and not cat.bad_blocks:
        wanted = {k: v for k, v in stats.channel_message_counts.items() if v}
        found = {k: v for k, v in counts.items() if v}
        if (wanted and wanted != found) or stats.message_count != sum(counts.values()):
            _fail(cat, recover, "the summary disagrees with the data: its statistics count "
                  f"{stats.message_count} messages, the chunks hold {sum(counts.values())}")
    cat.counts = counts
    cat.chunks_checked = True


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
               validate_crcs: bool = True) -> list[Schema | Channel | Message]:
    """The records of a block (a chunk, or a run of messages outside chunks), in file order;
    raises :class:`Malformed`."""
    f.seek(block.offset)
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
            chunk = ChunkHeader(**{**chunk.__dict__, "uncompressed_crc": 0})
        raw = decompress(chunk, data, limits)
        del data
        records = list(chunk_records(raw, limits))
        times = [r.log_time for r in records if isinstance(r, Message)]
        if times and (min(times) < chunk.start_ns or max(times) > chunk.end_ns):
            raise Malformed("messages outside the time range the chunk header declares")
        return records
    data = f.read(block.length)
    out: list[Schema | Channel | Message] = []
    pos = 0
    while pos + 9 <= len(data):
        length = int.from_bytes(data[pos + 1:pos + 9], "little")
        if data[pos] == 0x05:
            out.append(parse_message(data, pos + 9, min(len(data), pos + 9 + length)))
        pos += 9 + length
    return out
