"""One pass over an MCAP file's data section: where every chunk and message is, what damage
there is, and the data section's CRC.

The scan reads record headers and the small records (schemas, channels, metadata, chunk
headers) and streams over chunk data without keeping it, so memory stays flat. It is the
ground truth the summary is checked against (:mod:`replay.log.mcap_summary`) and what the reader
streams from (:mod:`replay.log.reader`).

Strict (the default): the first damaged record raises :class:`~replay.errors.CorruptLogError`
or :class:`~replay.errors.TruncatedLogError` naming the byte offset. ``recover=True``: damage
is recorded as :class:`Damage` and the scan resynchronises on the next intact chunk record.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

from mcap.records import Channel, Schema

from dsp.jsonio import Json
from estimator.constants import NS_PER_S
from replay.errors import CorruptLogError, TruncatedLogError
from replay.log.mcap_chunks import COMPRESSIONS
from replay.log.mcap_records import (
    FILE,
    MAGIC,
    BoundedStream,
    ChunkHeader,
    Cut,
    FileBytes,
    Limits,
    Malformed,
    Op,
    parse_channel,
    parse_chunk_header,
    parse_data_end,
    parse_header,
    parse_message,
    parse_metadata,
    parse_schema,
    record_head,
    record_name,
    walk,
)

__all__ = ["Block", "Damage", "DataScan", "scan_data"]

_RUN_BYTES = 4 * 1024 * 1024
"""Messages outside chunks are streamed in runs of about this many bytes."""
_RUN_MESSAGES = 4096


@dataclass
class Block:
    """What the reader loads as a whole: one chunk, or a run of messages outside chunks."""

    offset: int
    length: int
    start_ns: int
    end_ns: int
    chunk: ChunkHeader | None = None
    messages: int | None = None
    """How many messages: counted for a run; from the message index records for a chunk."""
    salvage: bool = False
    """The decodable prefix of a cut or damaged chunk (``--recover``): its records are
    salvaged (:func:`replay.log.mcap_chunks.salvage`), not decompressed whole."""


@dataclass(frozen=True)
class Damage:
    """A stretch of the file that could not be read."""

    offset: int
    length: int
    reason: str
    start_ns: int | None = None
    end_ns: int | None = None
    """The sim-time range the stretch held, when a chunk header says it."""
    messages: int | None = None
    chunks: int = 0
    """Chunks lost in it (whole or in part)."""

    def to_dict(self) -> dict[str, Json]:
        """A results file's ``log.recovered.lost`` entry."""
        return {"offset": self.offset, "bytes": self.length, "reason": self.reason,
                "start_s": None if self.start_ns is None else self.start_ns / NS_PER_S,
                "end_s": None if self.end_ns is None else self.end_ns / NS_PER_S,
                "messages": self.messages}


@dataclass
class DataScan:
    """The data section as found."""

    file_bytes: int
    profile: str | None = None
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    metadata_records: list[tuple[int, int, str]] = field(default_factory=list)
    """(offset, length, name) of every metadata record."""
    blocks: list[Block] = field(default_factory=list)
    data_end: int | None = None
    """Offset of the data end record (None: not reached)."""
    data_crc: int = 0
    """The CRC the data end record declares (0: none)."""
    data_crc_ok: bool | None = None
    damage: list[Damage] = field(default_factory=list)
    truncated: bool = False
    cut_chunk: ChunkHeader | None = None
    """The chunk the end of the file cuts, when its header is whole (``--recover`` salvages
    the decodable prefix of its data)."""

    @property
    def chunks(self) -> list[ChunkHeader]:
        return [b.chunk for b in self.blocks if b.chunk is not None]


def scan_data(f: IO[bytes], path: Path, size: int, limits: Limits, *,
              recover: bool) -> DataScan:
    """Scan the data section of the open file ``f`` (``size`` bytes)."""
    return _Scanner(f, path, size, limits, recover).run()


class _Scanner:
    def __init__(self, f: IO[bytes], path: Path, size: int, limits: Limits,
                 recover: bool) -> None:
        self.f, self.path, self.size, self.limits = f, path, size, limits
        self.recover = recover
        self.out = DataScan(size)
        self.crc: int | None = zlib.crc32(MAGIC)
        self.run_block: Block | None = None
        self.view = FileBytes(f, size)

    def fail(self, pos: int, reason: str, *, truncated: bool = False,
             chunk: ChunkHeader | None = None, in_chunk: bool = False) -> int | None:
        """Damage at ``pos``: raise (strict) or record it and return where to go on."""
        if not self.recover:
            if truncated:
                raise TruncatedLogError(self.path, f"byte {pos}: {reason}")
            raise CorruptLogError(self.path, f"byte {pos}: {reason}")
        self.crc = None
        self.close_run()
        nxt = None if truncated else self.resync(pos + 1)
        end = self.size if nxt is None else nxt
        self.out.damage.append(Damage(
            pos, end - pos, reason, None if chunk is None else chunk.message_start_time,
            None if chunk is None else chunk.message_end_time,
            chunks=1 if chunk is not None or in_chunk else 0))
        if nxt is None:
            self.out.truncated = True
        return nxt

    def read(self, pos: int, n: int) -> bytes:
        self.f.seek(pos)
        return self.f.read(n)

    def skip_body(self, pos: int, n: int) -> None:
        """Stream over ``n`` bytes at ``pos`` (only to keep the data CRC)."""
        if self.crc is None:
            return
        self.f.seek(pos)
        while n > 0:
            block = self.f.read(min(n, 1 << 20))
            if not block:
                return
            self.crc = zlib.crc32(block, self.crc)
            n -= len(block)

    def run(self) -> DataScan:
        head = self.read(0, 8)
        if head != MAGIC:  # checked by the caller; a short file ends here too
            raise TruncatedLogError(self.path, "no MCAP header")
        pos: int | None = 8
        while pos is not None:
            pos = self.walk_from(pos)
        self.close_run()
        return self.out

    def walk_from(self, pos: int) -> int | None:
        """Handle the records from ``pos`` on (:func:`walk`, the one record iterator) up to
        the data end, or to damage: then where to go on (None: nowhere)."""
        records = walk(self.view, FILE, start=pos)
        while True:
            try:
                rec = next(records, None)
            except Cut as err:
                at = err.at or 0
                chunk = (self.partial_chunk(at, err.length)
                         if err.op == Op.CHUNK and err.length is not None else None)
                return self.fail(at, str(err), truncated=True, chunk=chunk)
            except Malformed as err:  # opcode 0
                return self.fail(err.at or 0, str(err))
            if rec is None:
                return self.fail(self.size, "the log ends without a data end record or "
                                 "footer", truncated=True)
            op, body, end = rec
            pos, length = body - 9, end - body
            name = record_name(op, f"record (opcode {op:#x})")
            limit = self.limits.max_chunk_bytes + 1024 if op == Op.CHUNK else (
                self.limits.max_message_bytes)
            if op not in (Op.ATTACHMENT, Op.MESSAGE_INDEX) and length > limit:
                return self.fail(pos, f"a {name} of {length} bytes is over the limit of "
                                 f"{limit} bytes "
                                 f"({'--max-chunk-mib' if op == Op.CHUNK else 'a message'})")
            if op != Op.DATA_END:
                self.crc_update(bytes((op,)) + length.to_bytes(8, "little"))  # its head
            try:
                if self.record(pos, op, length):
                    return None
            except Malformed as err:
                return self.fail(pos, f"{name}: {err}", in_chunk=op == Op.CHUNK)

    def record(self, pos: int, op: int, length: int) -> bool:
        """Parse one record (its header is read); True when the data section ends here."""
        body_pos = pos + 9
        if op == Op.MESSAGE:
            body = self.read(body_pos, length)
            self.crc_update(body)
            msg = parse_message(body)
            self.add_to_run(pos, 9 + length, msg.log_time)
            return False
        self.close_run()  # a run is messages only, one after the other
        if op == Op.CHUNK:
            self.chunk(pos, length)
        elif op == Op.DATA_END:
            body = self.read(body_pos, length)
            self.out.data_crc = parse_data_end(body).data_section_crc
            self.out.data_end = pos
            if self.out.data_crc and self.crc is not None:
                self.out.data_crc_ok = self.crc == self.out.data_crc
            return True
        elif op == Op.FOOTER:
            return True
        elif op == Op.MESSAGE_INDEX:
            self.message_index(self.read(body_pos, min(length, 6)))
            self.skip_body(body_pos, length)
        elif op in (Op.SCHEMA, Op.CHANNEL, Op.METADATA, Op.HEADER):
            body = self.read(body_pos, length)
            self.crc_update(body)
            self.small(pos, op, length, body)
        else:
            self.skip_body(body_pos, length)
        return False

    def crc_update(self, body: bytes) -> None:
        if self.crc is not None:
            self.crc = zlib.crc32(body, self.crc)

    def small(self, pos: int, op: int, length: int, body: bytes) -> None:
        out = self.out
        if op == Op.SCHEMA:
            s = parse_schema(body)
            out.schemas[s.id] = s
        elif op == Op.CHANNEL:
            c = parse_channel(body)
            out.channels[c.id] = c
        elif op == Op.METADATA:
            m = parse_metadata(body)
            out.metadata[m.name] = m.metadata
            out.metadata_records.append((pos, 9 + length, m.name))
        elif op == Op.HEADER and pos == 8:
            try:  # only shown by dsp-info: a damaged header costs nothing else
                out.profile = parse_header(body).profile
            except Malformed:
                out.profile = None

    def message_index(self, head: bytes) -> None:
        """Count a chunk's messages from the message index records after it."""
        blocks = self.out.blocks
        if len(head) >= 6 and blocks and blocks[-1].chunk is not None:
            s = BoundedStream(head)
            s.read2()  # the channel id
            entries = s.read4() // 16
            blocks[-1].messages = (blocks[-1].messages or 0) + entries

    def chunk_header(self, pos: int, length: int, *, whole: bool = True) -> ChunkHeader:
        head = self.read(pos + 9, min(length, 1024))
        chunk = parse_chunk_header(head, pos, length, whole=whole)
        if chunk.compression not in COMPRESSIONS:
            raise Malformed(f"unknown compression {chunk.compression[:20]!r}")
        if chunk.message_start_time > chunk.message_end_time:
            raise Malformed("its time range ends before it starts")
        if chunk.uncompressed_size > self.limits.max_chunk_bytes:
            raise Malformed(f"it declares {chunk.uncompressed_size} bytes uncompressed, over "
                            f"the limit of {self.limits.max_chunk_bytes} (--max-chunk-mib)")
        return chunk

    def chunk(self, pos: int, length: int) -> None:
        chunk = self.chunk_header(pos, length)
        self.out.blocks.append(Block(pos, chunk.length, chunk.message_start_time,
                                     chunk.message_end_time, chunk))
        self.skip_body(pos + 9, length)

    def partial_chunk(self, pos: int, length: int) -> ChunkHeader | None:
        """The header of a chunk cut by the end of the file, if it is all there (kept for
        salvage when its data would fill the record), else its time range alone."""
        try:
            chunk = self.chunk_header(pos, length, whole=False)
            if chunk.data_offset + chunk.data_length == pos + chunk.length:
                self.out.cut_chunk = chunk
            return chunk
        except Malformed:
            head = self.read(pos + 9, 16)
            if len(head) == 16:
                s = BoundedStream(head)
                start, end = s.read8(), s.read8()
                return ChunkHeader(pos, 9 + length, start, end, 0, 0, "", 0, 0)
            return None

    def add_to_run(self, pos: int, n: int, log_time: int) -> None:
        run = self.run_block
        if run is None or run.length + n > _RUN_BYTES or (run.messages or 0) >= _RUN_MESSAGES:
            self.close_run()
            run = self.run_block = Block(pos, 0, log_time, log_time, None, 0)
        run.length += n
        run.messages = (run.messages or 0) + 1
        run.start_ns = min(run.start_ns, log_time)
        run.end_ns = max(run.end_ns, log_time)

    def close_run(self) -> None:
        if self.run_block is not None:
            self.out.blocks.append(self.run_block)
            self.run_block = None

    def resync(self, start: int) -> int | None:
        """The offset of the next intact chunk record after ``start``, None if there is none."""
        window = 1 << 20
        pos = start
        while pos < self.size - 9:
            buf = self.read(pos, window + 64)
            i = buf.find(bytes([Op.CHUNK]))
            while 0 <= i < window:
                cand = pos + i
                head = buf[i:i + 9]
                if len(head) == 9:
                    length = record_head(head)[1]
                    if length <= self.size - cand - 9:
                        try:
                            self.chunk_header(cand, length)
                            return cand
                        except Malformed:
                            pass
                i = buf.find(bytes([Op.CHUNK]), i + 1)
            pos += window
        return None
