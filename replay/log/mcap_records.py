"""MCAP records, parsed by :mod:`mcap.records` through a stream that cannot read past them.

The MCAP layout (https://mcap.dev/spec): magic, then records ``opcode u8, length u64, body``,
then magic again. ``mcap.records.X.read(stream)`` parses a record body from any
:class:`mcap.data_stream.ReadDataStream`; here that stream is a :class:`BoundedStream` over
one record's bytes, already in memory and length-checked by the caller, so a damaged field
can never read into the next record or allocate more than the record holds: it raises
:class:`Malformed` with a short reason, which the callers turn into an error naming the file
and the byte offset. The records keep mcap's own classes and field names (``Schema``,
``Channel``, ``Footer``, ``ChunkIndex``, ``Statistics``, ...), so the ROS 2 decoders accept
them as they are.

What mcap lacks is here too: :func:`walk`, the one iterator over the records of a buffer
(a chunk, the summary, a run of messages, or the data section in the file itself) that
checks every record's length before its body is touched; :func:`parse_chunk_header`, a
chunk's fields without its data; and the fast path for messages (:func:`parse_message`,
one ``struct`` call per message).
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from typing import IO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
)

__all__ = [
    "CHUNK",
    "DEFAULT_MAX_CHUNK_BYTES",
    "DEFAULT_MAX_MESSAGE_BYTES",
    "FILE",
    "MAGIC",
    "RUN",
    "SUMMARY",
    "BoundedStream",
    "ChunkHeader",
    "Cut",
    "FileBytes",
    "Limits",
    "Malformed",
    "Op",
    "Region",
    "chunk_records",
    "parse_channel",
    "parse_chunk_header",
    "parse_chunk_index",
    "parse_data_end",
    "parse_footer",
    "parse_header",
    "parse_message",
    "parse_metadata",
    "parse_metadata_index",
    "parse_schema",
    "parse_statistics",
    "record_head",
    "record_name",
    "walk",
]

MAGIC = b"\x89MCAP0\r\n"
DEFAULT_MAX_MESSAGE_BYTES = 64 * 1024 * 1024
DEFAULT_MAX_CHUNK_BYTES = 128 * 1024 * 1024

Op = Opcode
"""The record opcodes (mcap's own enumeration)."""

_HEAD = struct.Struct("<BQ")
_MESSAGE = struct.Struct("<HIQQ")
"""A message's fixed fields: channel id, sequence, log time, publish time."""


def record_name(op: int, unknown: str = "record") -> str:
    """A record kind in words ("message index"); ``unknown`` for an opcode mcap lacks."""
    try:
        return Opcode(op).name.lower().replace("_", " ")
    except ValueError:
        return unknown


@dataclass(frozen=True)
class Limits:
    """Sizes a log may declare before it is refused (bytes)."""

    max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES
    """Largest record outside a chunk, and largest message anywhere."""
    max_chunk_bytes: int = DEFAULT_MAX_CHUNK_BYTES
    """Largest chunk, compressed or as its header declares it uncompressed."""


class Malformed(Exception):
    """A record does not parse; the message says what is wrong (``at``: the record's file
    offset, when it is known)."""

    def __init__(self, reason: str, *, at: int | None = None) -> None:
        super().__init__(reason)
        self.at = at


class Cut(Malformed):
    """The buffer ends inside a record: inside its header, or (``op`` and ``length`` known)
    before the end of the body its header declares."""

    def __init__(self, reason: str, *, at: int, op: int | None = None,
                 length: int | None = None) -> None:
        super().__init__(reason, at=at)
        self.op, self.length = op, length


class BoundedStream(ReadDataStream):
    """The bytes ``buf[pos:end]`` as mcap's read stream, refusing any read past ``end``."""

    def __init__(self, buf: bytes, pos: int = 0, end: int | None = None) -> None:
        super().__init__(io.BytesIO(b""))
        self._buf = buf
        self._start = self._pos = pos
        self._end = len(buf) if end is None else end

    @property
    def count(self) -> int:
        return self._pos - self._start

    @property
    def remaining(self) -> int:
        return self._end - self._pos

    def read(self, length: int) -> bytes:
        if length < 0 or length > self._end - self._pos:
            raise Malformed(f"a field of {length} bytes runs past its record")
        out = self._buf[self._pos:self._pos + length]
        self._pos += length
        return out

    def read_prefixed_string(self, most: int | None = None) -> str:
        """A length-prefixed UTF-8 string (``most``: the longest it may be, in bytes)."""
        n = self.read4()
        if most is not None and n > most:
            raise Malformed(f"a string of {n} bytes where at most {most} are expected")
        raw = self.read(n)
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as err:
            raise Malformed("a string is not UTF-8") from err


def parse_footer(body: bytes) -> Footer:
    out: Footer = Footer.read(BoundedStream(body))
    return out


def parse_header(body: bytes) -> Header:
    out: Header = Header.read(BoundedStream(body))
    return out


def parse_schema(body: bytes, pos: int = 0, end: int | None = None) -> Schema:
    out: Schema = Schema.read(BoundedStream(body, pos, end))
    return out


def parse_channel(body: bytes, pos: int = 0, end: int | None = None) -> Channel:
    out: Channel = Channel.read(BoundedStream(body, pos, end))
    return out


def parse_metadata(body: bytes) -> Metadata:
    out: Metadata = Metadata.read(BoundedStream(body))
    return out


def parse_data_end(body: bytes) -> DataEnd:
    out: DataEnd = DataEnd.read(BoundedStream(body))
    return out


def parse_chunk_index(body: bytes) -> ChunkIndex:
    out: ChunkIndex = ChunkIndex.read(BoundedStream(body))
    return out


def parse_statistics(body: bytes) -> Statistics:
    out: Statistics = Statistics.read(BoundedStream(body))
    return out


def parse_metadata_index(body: bytes) -> MetadataIndex:
    out: MetadataIndex = MetadataIndex.read(BoundedStream(body))
    return out


def parse_message(buf: bytes, pos: int = 0, end: int | None = None) -> Message:
    """The message whose body is ``buf[pos:end]``: the fast path, one ``struct`` call and
    one slice (``mcap.records.Message.read`` reads the same fields one at a time)."""
    end = len(buf) if end is None else end
    if end - pos < _MESSAGE.size:
        raise Malformed(f"a message's {_MESSAGE.size} bytes of fixed fields: a field runs "
                        f"past its record of {max(0, end - pos)} bytes")
    cid, seq, log_time, publish_time = _MESSAGE.unpack_from(buf, pos)
    return Message(channel_id=cid, sequence=seq, log_time=log_time, publish_time=publish_time,
                   data=buf[pos + _MESSAGE.size:end])


@dataclass(frozen=True)
class ChunkHeader:
    """A chunk record's fields without its data (mcap's ``Chunk`` names); ``offset`` is where
    the record starts in the file."""

    offset: int
    length: int
    """The whole record, opcode and length included."""
    message_start_time: int
    message_end_time: int
    uncompressed_size: int
    uncompressed_crc: int
    compression: str
    data_offset: int
    """Where the compressed records start in the file."""
    data_length: int


def parse_chunk_header(head: bytes, offset: int, length: int, *,
                       whole: bool = True) -> ChunkHeader:
    """The fields of a chunk record of ``length`` body bytes at file ``offset``, from the
    first bytes of its body (``head``: at least the fixed fields and the compression).
    ``whole``: the data must fill the record exactly (False: a chunk the end of the file
    cuts, whose data may declare more than the file holds)."""
    s = BoundedStream(head)
    start, end, size, crc = s.read8(), s.read8(), s.read8(), s.read4()
    try:
        compression = s.read_prefixed_string(most=64)
    except Malformed as err:
        raise Malformed(f"its compression name: {err}") from err
    data_length = s.read8()
    if whole and s.count + data_length != length:
        raise Malformed(f"chunk data of {data_length} bytes does not fill its record "
                        f"of {length} bytes")
    return ChunkHeader(offset, 9 + length, start, end, size, crc, compression,
                       offset + 9 + s.count, data_length)


@dataclass(frozen=True)
class Region:
    """A buffer of records :func:`walk` goes over, for the words of its errors (fields
    ``{name}``, ``{length}``, ``{size}`` and ``{at}``, the record's file offset when it is
    known)."""

    cut_header: str
    past_end: str
    opcode_zero: str


CHUNK = Region("chunk ends inside a record header",
               "a {name} in a chunk declares {length} bytes, past the chunk's end",
               "a record in a chunk has opcode 0")
SUMMARY = Region("the summary ends inside a record header",
                 "a summary record at byte {at} runs past the summary",
                 "a summary record at byte {at} has opcode 0")
RUN = Region("the messages at byte {at} end inside a record header",
             "a {name} at byte {at} declares {length} bytes, past the messages scanned",
             "a record at byte {at} has opcode 0")
FILE = Region("the log ends inside a record header",
              "a {name} of {length} bytes runs past the end of the file ({size} bytes)",
              "a record with opcode 0")
"""The data section, walked in the file itself (:class:`FileBytes`)."""


class FileBytes:
    """An open file of ``size`` bytes as :func:`walk` reads a buffer: its length, and
    slices (each one seek and one read), so the data section is walked without being held."""

    def __init__(self, f: IO[bytes], size: int) -> None:
        self.f, self.size = f, size

    def __len__(self) -> int:
        return self.size

    def __getitem__(self, part: slice) -> bytes:
        self.f.seek(part.start)
        return self.f.read(part.stop - part.start)


def record_head(head: bytes) -> tuple[int, int]:
    """``(opcode, body length)`` from a record's first 9 bytes."""
    op, length = _HEAD.unpack_from(head)
    return int(op), int(length)


def walk(buf: bytes | FileBytes, region: Region, base: int = 0,
         start: int = 0) -> Iterator[tuple[int, int, int]]:
    """``(opcode, body start, body end)`` of each record in ``buf`` from ``start`` on, in
    order: the one iterator over records, for a chunk, the summary, a run of messages and
    the file's data section. Every length is checked against the buffer before the record
    is yielded, so a body never runs past it. ``base``: the file offset of ``buf[0]`` (for
    the errors). Raises :class:`Cut` where the buffer ends inside a record and
    :class:`Malformed` at a record with opcode 0, the first record that does not fit."""
    pos, end = start, len(buf)
    while pos < end:
        head = buf[pos:pos + 9]
        if len(head) < 9:
            raise Cut(region.cut_header.format(at=base + pos), at=base + pos)
        op, length = record_head(head)
        if op == 0:
            raise Malformed(region.opcode_zero.format(at=base + pos), at=base + pos)
        body = pos + 9
        if length > end - body:
            name = record_name(op, f"record (opcode {op:#x})")
            raise Cut(region.past_end.format(name=name, length=length, at=base + pos,
                                             size=end), at=base + pos, op=op, length=length)
        yield op, body, body + length
        pos = body + length


def chunk_records(data: bytes, limits: Limits) -> Iterator[Schema | Channel | Message]:
    """Schema, channel and message records of an uncompressed chunk, in order."""
    for op, start, end in walk(data, CHUNK):
        if op == Op.MESSAGE:
            if end - start > limits.max_message_bytes:
                raise Malformed(f"a message of {end - start} bytes is over the limit of "
                                f"{limits.max_message_bytes}")
            yield parse_message(data, start, end)
        elif op == Op.SCHEMA:
            yield parse_schema(data, start, end)
        elif op == Op.CHANNEL:
            yield parse_channel(data, start, end)
