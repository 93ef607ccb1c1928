"""MCAP records, parsed with every length bounded before anything is allocated.

The MCAP layout (https://mcap.dev/spec): magic, then records ``opcode u8, length u64, body``,
then magic again. This module reads single records from bytes already in memory (whose size
the caller bounded), so a damaged length field can never make it allocate more than the
record it was given. Anything malformed raises :class:`Malformed` with a short reason; the
callers turn it into an error naming the file and the byte offset.

Schema, channel and message records come out as :mod:`mcap.records` objects so the ROS 2
decoders accept them; the rest as small frozen dataclasses.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from typing import ClassVar

from mcap.records import Channel, Message, Schema

__all__ = [
    "DEFAULT_MAX_CHUNK_BYTES",
    "DEFAULT_MAX_MESSAGE_BYTES",
    "MAGIC",
    "ChunkHeader",
    "ChunkIndex",
    "Footer",
    "Limits",
    "Malformed",
    "MetadataIndex",
    "Op",
    "Statistics",
    "chunk_records",
    "decompress",
    "parse_channel",
    "parse_chunk_header",
    "parse_chunk_index",
    "parse_footer",
    "parse_message",
    "parse_metadata",
    "parse_metadata_index",
    "parse_schema",
    "parse_statistics",
]

MAGIC = b"\x89MCAP0\r\n"
DEFAULT_MAX_MESSAGE_BYTES = 64 * 1024 * 1024
DEFAULT_MAX_CHUNK_BYTES = 128 * 1024 * 1024


class Op:
    """Record opcodes of the MCAP spec."""

    HEADER = 0x01
    FOOTER = 0x02
    SCHEMA = 0x03
    CHANNEL = 0x04
    MESSAGE = 0x05
    CHUNK = 0x06
    MESSAGE_INDEX = 0x07
    CHUNK_INDEX = 0x08
    ATTACHMENT = 0x09
    ATTACHMENT_INDEX = 0x0A
    STATISTICS = 0x0B
    METADATA = 0x0C
    METADATA_INDEX = 0x0D
    SUMMARY_OFFSET = 0x0E
    DATA_END = 0x0F

    NAMES: ClassVar[dict[int, str]] = {
        0x01: "header", 0x02: "footer", 0x03: "schema", 0x04: "channel", 0x05: "message",
        0x06: "chunk", 0x07: "message index", 0x08: "chunk index", 0x09: "attachment",
        0x0A: "attachment index", 0x0B: "statistics", 0x0C: "metadata",
        0x0D: "metadata index", 0x0E: "summary offset", 0x0F: "data end",
    }


@dataclass(frozen=True)
class Limits:
    """Sizes a log may declare before it is refused (bytes)."""

    max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES
    """Largest record outside a chunk, and largest message anywhere."""
    max_chunk_bytes: int = DEFAULT_MAX_CHUNK_BYTES
    """Largest chunk, compressed or as its header declares it uncompressed."""


class Malformed(Exception):
    """A record does not parse; the message says what is wrong."""


class _Cursor:
    """Reads little-endian fields from a buffer, never past ``end``."""

    __slots__ = ("buf", "end", "pos")

    def __init__(self, buf: bytes, pos: int = 0, end: int | None = None) -> None:
        self.buf = buf
        self.pos = pos
        self.end = len(buf) if end is None else end

    def take(self, n: int) -> bytes:
        if n < 0 or n > self.end - self.pos:
            raise Malformed(f"a field of {n} bytes runs past its record")
        out = self.buf[self.pos:self.pos + n]
        self.pos += n
        return out

    def u8(self) -> int:
        return int(self.take(1)[0])

    def u16(self) -> int:
        return int(struct.unpack("<H", self.take(2))[0])

    def u32(self) -> int:
        return int(struct.unpack("<I", self.take(4))[0])

    def u64(self) -> int:
        return int(struct.unpack("<Q", self.take(8))[0])

    def string(self) -> str:
        raw = self.take(self.u32())
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as err:
            raise Malformed("a string is not UTF-8") from err

    def sub(self, n: int) -> _Cursor:
        if n < 0 or n > self.end - self.pos:
            raise Malformed(f"a map of {n} bytes runs past its record")
        c = _Cursor(self.buf, self.pos, self.pos + n)
        self.pos += n
        return c

    def str_map(self) -> dict[str, str]:
        c = self.sub(self.u32())
        out: dict[str, str] = {}
        while c.pos < c.end:
            key = c.string()
            out[key] = c.string()
        return out

    def u16_u64_map(self) -> dict[int, int]:
        c = self.sub(self.u32())
        out: dict[int, int] = {}
        while c.pos < c.end:
            key = c.u16()
            out[key] = c.u64()
        return out


@dataclass(frozen=True)
class Footer:
    summary_start: int
    summary_offset_start: int
    summary_crc: int


@dataclass(frozen=True)
class ChunkHeader:
    """A chunk record's fields, without its data; ``offset`` is where the record starts."""

    offset: int
    length: int
    """The whole record, opcode and length included."""
    start_ns: int
    end_ns: int
    uncompressed_size: int
    uncompressed_crc: int
    compression: str
    data_offset: int
    """Where the compressed records start in the file."""
    data_length: int


@dataclass(frozen=True)
class ChunkIndex:
    start_ns: int
    end_ns: int
    chunk_offset: int
    chunk_length: int
    compression: str
    compressed_size: int
    uncompressed_size: int


@dataclass(frozen=True)
class Statistics:
    message_count: int
    schema_count: int
    channel_count: int
    metadata_count: int
    chunk_count: int
    start_ns: int
    end_ns: int
    channel_message_counts: dict[int, int]


@dataclass(frozen=True)
class MetadataIndex:
    offset: int
    length: int
    name: str


def parse_footer(body: bytes) -> Footer:
    c = _Cursor(body)
    return Footer(c.u64(), c.u64(), c.u32())


def parse_schema(body: bytes) -> Schema:
    c = _Cursor(body)
    sid = c.u16()
    name, encoding = c.string(), c.string()
    data = c.take(c.u32())
    return Schema(id=sid, name=name, encoding=encoding, data=data)


def parse_channel(body: bytes) -> Channel:
    c = _Cursor(body)
    cid, sid = c.u16(), c.u16()
    topic, encoding = c.string(), c.string()
    return Channel(id=cid, schema_id=sid, topic=topic, message_encoding=encoding,
                   metadata=c.str_map())


def parse_message(body: bytes, pos: int = 0, end: int | None = None) -> Message:
    c = _Cursor(body, pos, end)
    cid, seq, log_time, publish_time = c.u16(), c.u32(), c.u64(), c.u64()
    return Message(channel_id=cid, sequence=seq, log_time=log_time, publish_time=publish_time,
                   data=c.take(c.end - c.pos))


def parse_chunk_header(head: bytes, offset: int, length: int) -> ChunkHeader:
    """The fields of a chunk record of ``length`` body bytes at file ``offset``, from the
    first bytes of its body (``head``: at least the fixed fields and the compression)."""
    c = _Cursor(head)
    start, end, size, crc = c.u64(), c.u64(), c.u64(), c.u32()
    compression = c.string()
    data_length = c.u64()
    if c.pos + data_length != length:
        raise Malformed(f"chunk data of {data_length} bytes does not fill its record "
                        f"of {length} bytes")
    return ChunkHeader(offset, 9 + length, start, end, size, crc, compression,
                       offset + 9 + c.pos, data_length)


def parse_chunk_index(body: bytes) -> ChunkIndex:
    c = _Cursor(body)
    start, end, offset, length = c.u64(), c.u64(), c.u64(), c.u64()
    c.u16_u64_map()  # message index offsets: not needed, whole chunks are read
    c.u64()  # message index length
    compression = c.string()
    return ChunkIndex(start, end, offset, length, compression, c.u64(), c.u64())


def parse_statistics(body: bytes) -> Statistics:
    c = _Cursor(body)
    messages, schemas, channels = c.u64(), c.u16(), c.u32()
    c.u32()  # attachments
    metadata, chunks, start, end = c.u32(), c.u32(), c.u64(), c.u64()
    return Statistics(messages, schemas, channels, metadata, chunks, start, end,
                      c.u16_u64_map())


def parse_metadata(body: bytes) -> tuple[str, dict[str, str]]:
    c = _Cursor(body)
    return c.string(), c.str_map()


def parse_metadata_index(body: bytes) -> MetadataIndex:
    c = _Cursor(body)
    return MetadataIndex(c.u64(), c.u64(), c.string())


def decompress(chunk: ChunkHeader, data: bytes, limits: Limits) -> bytes:
    """A chunk's records, uncompressed and CRC-checked; never more than the header declares
    (and the header never more than the limit)."""
    size = chunk.uncompressed_size
    if size > limits.max_chunk_bytes:
        raise Malformed(f"chunk declares {size} bytes uncompressed, over the limit of "
                        f"{limits.max_chunk_bytes} (raise --max-chunk-mib)")
    if chunk.compression == "":
        out = data
    elif chunk.compression == "zstd":
        out = _unzstd(data, size)
    elif chunk.compression == "lz4":
        out = _unlz4(data, size)
    else:
        raise Malformed(f"unknown chunk compression {chunk.compression[:20]!r}")
    if len(out) > size:
        raise Malformed(f"chunk decompresses to more than the {size} bytes its header declares")
    if len(out) < size:
        raise Malformed(f"chunk decompresses to {len(out)} bytes, its header declares {size}")
    if chunk.uncompressed_crc != 0 and zlib.crc32(out) != chunk.uncompressed_crc:
        raise Malformed("chunk CRC mismatch")
    return out


def _unzstd(data: bytes, size: int) -> bytes:
    import zstandard

    try:
        reader = zstandard.ZstdDecompressor().stream_reader(data)
        parts: list[bytes] = []
        total = 0
        while total <= size:
            block = reader.read(min(1 << 20, size + 1 - total))
            if not block:
                break
            parts.append(block)
            total += len(block)
        return b"".join(parts)
    except zstandard.ZstdError as err:
        raise Malformed(f"zstd: {err}") from err


def _unlz4(data: bytes, size: int) -> bytes:
    import lz4.frame

    try:
        return bytes(lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=size + 1))
    except RuntimeError as err:
        raise Malformed(f"lz4: {err}") from err


def chunk_records(data: bytes, limits: Limits) -> Iterator[Schema | Channel | Message]:
    """Schema, channel and message records of an uncompressed chunk, in order."""
    pos, end = 0, len(data)
    while pos < end:
        if end - pos < 9:
            raise Malformed("chunk ends inside a record header")
        op, length = struct.unpack_from("<BQ", data, pos)
        body_start = pos + 9
        if length > end - body_start:
            raise Malformed(f"a {Op.NAMES.get(op, 'record')} in a chunk declares {length} "
                            "bytes, past the chunk's end")
        if op == 0:
            raise Malformed("a record in a chunk has opcode 0")
        if op == Op.MESSAGE:
            if length > limits.max_message_bytes:
                raise Malformed(f"a message of {length} bytes is over the limit of "
                                f"{limits.max_message_bytes}")
            yield parse_message(data, body_start, body_start + length)
        elif op == Op.SCHEMA:
            yield parse_schema(data[body_start:body_start + length])
        elif op == Op.CHANNEL:
            yield parse_channel(data[body_start:body_start + length])
        pos = body_start + length
