"""Reading and rewriting (trusted) logs for the fuzz harness and the tests, and an
independent reader of what a cut log holds.

:func:`read_raw` / :func:`write_raw` take a log apart with the mcap library and write it
again in any layout; :func:`records` lists a well-formed file's records;
:func:`messages_before_cut` is the reference for ``--recover``: the messages that mcap's own
reader and the zstandard / lz4 streaming decoders find in the bytes before a cut.
"""

from __future__ import annotations

import io
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, Message
from mcap.stream_reader import breakup_chunk
from mcap.writer import CompressionType, Writer

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "logs" / "golden"
MAGIC = b"\x89MCAP0\r\n"


# --- reading and rewriting a (trusted) log ---------------------------------------------------
@dataclass
class Raw:
    schemas: dict[int, tuple[str, str, bytes]]
    channels: dict[int, tuple[str, int, str, dict[str, str]]]
    messages: list[tuple[int, int, int, int, bytes]]
    """(channel id, sequence, log time, publish time, data)"""
    metadata: list[tuple[str, dict[str, str]]]


def read_raw(path: Path) -> Raw:
    with path.open("rb") as f:
        return raw_from_reader(make_reader(f))


def write_raw(raw: Raw, **options: Any) -> bytes:
    """``raw`` as an MCAP file written by the mcap library with ``options`` (its Writer's
    keyword arguments: chunk_size, compression, use_chunking, use_statistics, ...)."""
    out = io.BytesIO()
    w = Writer(out, **options)
    w.start(profile="ros2", library="dsp-fuzz")
    sid_map = {sid: w.register_schema(name, enc, data)
               for sid, (name, enc, data) in sorted(raw.schemas.items())}
    cid_map = {cid: w.register_channel(topic, enc, sid_map[sid], meta)
               for cid, (topic, sid, enc, meta) in sorted(raw.channels.items())}
    for name, data in raw.metadata:
        w.add_metadata(name, data)
    for cid, seq, log_time, publish_time, data in raw.messages:
        w.add_message(cid_map[cid], log_time, data, publish_time, seq)
    w.finish()
    return out.getvalue()


RECORDER_LAYOUT: dict[str, Any] = {"compression": CompressionType.ZSTD,
                                   "chunk_size": 4 * 1024 * 1024}


def seed_log(scene: str = "scenario2", until_s: float = 0.3, **options: Any) -> bytes:
    """A golden log's first ``until_s`` seconds, rewritten (recorder's layout by default)."""
    raw = read_raw(GOLDEN / f"{scene}.mcap")
    raw.messages = [m for m in raw.messages if m[2] < until_s * 1e9]
    return write_raw(raw, **{**RECORDER_LAYOUT, **options})


# --- the file's records ----------------------------------------------------------------------
@dataclass(frozen=True)
class Rec:
    offset: int
    op: int
    length: int
    region: str
    """data / summary / footer"""


def records(data: bytes) -> list[Rec]:
    """The records of a well-formed file, in order (the summary's included)."""
    out, pos = [], 8
    region = "data"
    while pos + 9 <= len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, pos)
        out.append(Rec(pos, op, length, region))
        if op == 0x0F:
            region = "summary"
        pos += 9 + length
        if op == 0x02:
            break
    return [Rec(r.offset, r.op, r.length, "footer" if r.op == 0x02 else r.region) for r in out]


def raw_from_reader(reader: Any) -> Raw:
    schemas, channels, messages = {}, {}, []
    for schema, channel, msg in reader.iter_messages(log_time_order=False):
        if schema is not None:
            schemas[schema.id] = (schema.name, schema.encoding, schema.data)
        channels[channel.id] = (channel.topic, channel.schema_id, channel.message_encoding,
                                dict(channel.metadata))
        messages.append((msg.channel_id, msg.sequence, msg.log_time, msg.publish_time,
                         msg.data))
    metadata = [(m.name, dict(m.metadata)) for m in reader.iter_metadata()]
    return Raw(schemas, channels, messages, metadata)


def zstd_block_headers(data: bytes) -> list[int]:
    """The offsets of the block headers of the zstd frame ``data`` (RFC 8878, 3.1.1), to
    damage one block of a chunk on purpose."""
    fhd = data[4]
    single, fcs, did = (fhd >> 5) & 1, fhd >> 6, fhd & 3
    pos = 5 + (0 if single else 1) + (0, 1, 2, 4)[did] + ((1 if single else 0), 2, 4, 8)[fcs]
    out = []
    while pos + 3 <= len(data):
        out.append(pos)
        head = int.from_bytes(data[pos:pos + 3], "little")
        pos += 3 + (1 if (head >> 1) & 3 == 1 else head >> 3)
        if head & 1:
            break
    return out


def _whole_records(raw: bytes) -> bytes:
    """The whole records at the start of ``raw``, an uncompressed chunk's prefix (mcap's
    own parser does not check that a record fits)."""
    pos = 0
    while pos + 9 <= len(raw):
        length = struct.unpack_from("<Q", raw, pos + 1)[0]
        if pos + 9 + length > len(raw):
            break
        pos += 9 + length
    return raw[:pos]


def _cut_chunk(chunk: Chunk) -> Chunk:
    """What the streaming decoders make of a cut chunk's data: its whole records."""
    data = chunk.data
    raw = (zstandard.ZstdDecompressor().decompressobj().decompress(data)
           if chunk.compression == "zstd" else
           lz4.frame.LZ4FrameDecompressor().decompress(data)
           if chunk.compression == "lz4" else data)
    raw = _whole_records(raw)
    return Chunk(compression="", data=raw, message_end_time=0, message_start_time=0,
                 uncompressed_crc=0, uncompressed_size=len(raw))


def messages_before_cut(log: bytes, cut: int) -> tuple[list[Message], dict[int, str]]:
    """The messages in ``log[:cut]`` (``log`` whole and well-formed), in file order, and
    the topics of the channels defined there: every chunk that ends before the cut, read
    by ``mcap``; of the chunk the cut falls in, the whole records of what the decoders make
    of its bytes before the cut; of messages outside chunks, those whose record ends before
    the cut."""
    out: list[Message] = []
    topics: dict[int, str] = {}
    for r in records(log):
        end = r.offset + 9 + r.length
        if r.region != "data" or r.offset + 9 > cut:
            continue
        if r.op == 0x05 and end <= cut:
            out.append(Message.read(ReadDataStream(io.BytesIO(log[r.offset + 9:end])),
                                    r.length))
        elif r.op == 0x04 and end <= cut:
            channel = Channel.read(ReadDataStream(io.BytesIO(log[r.offset + 9:end])))
            topics[channel.id] = channel.topic
        if r.op != 0x06:
            continue
        try:
            chunk = Chunk.read(ReadDataStream(io.BytesIO(log[r.offset + 9:min(end, cut)])))
        except EndOfFile:  # the cut is inside its header or where its data starts
            continue
        for rec in breakup_chunk(chunk if end <= cut else _cut_chunk(chunk),
                                 validate_crc=True):
            if isinstance(rec, Message):
                out.append(rec)
            elif isinstance(rec, Channel):
                topics[rec.id] = rec.topic
    return out, topics
