"""replay.log.mcap_records: mcap's own record classes read through a bounded stream, the one
record iterator, the header-only chunk parse and the fast message path."""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

import pytest
from mcap.data_stream import RecordBuilder
from mcap.records import (
    Channel,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Message,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
)

from replay.log.mcap_records import (
    CHUNK,
    RUN,
    SUMMARY,
    BoundedStream,
    Limits,
    Malformed,
    Op,
    chunk_records,
    parse_channel,
    parse_chunk_header,
    parse_chunk_index,
    parse_data_end,
    parse_footer,
    parse_header,
    parse_message,
    parse_metadata,
    parse_metadata_index,
    parse_schema,
    parse_statistics,
    record_name,
    walk,
)

RECORDS: list[tuple[McapRecord, Callable[[bytes], Any]]] = [
    (Header(profile="ros2", library="dsp"), parse_header),
    (Footer(summary_start=100, summary_offset_start=200, summary_crc=7), parse_footer),
    (Schema(id=3, data=b"float64 x\n", encoding="ros2msg", name="std_msgs/msg/Float64"),
     parse_schema),
    (Channel(id=2, topic="/robot1/pose", message_encoding="cdr",
             metadata={"a": "1", "bb": "22"}, schema_id=3), parse_channel),
    (Metadata(name="dsp.scenario", metadata={"name": "rolling", "seed": "0"}),
     parse_metadata),
    (MetadataIndex(offset=70, length=40, name="dsp.scenario"), parse_metadata_index),
    (DataEnd(data_section_crc=0xDEADBEEF), parse_data_end),
    (ChunkIndex(chunk_length=900, chunk_start_offset=80, compression="zstd",
                compressed_size=700, message_end_time=20, message_index_length=50,
                message_index_offsets={1: 980, 2: 1000}, message_start_time=10,
                uncompressed_size=2000), parse_chunk_index),
    (Statistics(attachment_count=0, channel_count=2, channel_message_counts={1: 3, 2: 4},
                chunk_count=1, message_count=7, message_end_time=20, message_start_time=10,
                metadata_count=1, schema_count=1), parse_statistics),
]


def _body(record: McapRecord) -> bytes:
    """The body mcap's own writer gives ``record`` (without opcode and length)."""
    builder = RecordBuilder()
    record.write(builder)
    return builder.end()[9:]


@pytest.mark.parametrize(("record", "parse"), RECORDS, ids=lambda r: type(r).__name__)
def test_records_read_back_as_mcaps_own_classes(record: McapRecord,
                                                parse: Callable[[bytes], Any]) -> None:
    """What mcap's writer writes, the bounded parser reads back as the same mcap record."""
    body = _body(record)
    assert parse(body) == record
    assert parse(body + b"a field a later version adds") == record  # the spec lets records grow


@pytest.mark.parametrize(("record", "parse"), RECORDS, ids=lambda r: type(r).__name__)
def test_every_cut_of_a_record_is_malformed(record: McapRecord,
                                            parse: Callable[[bytes], Any]) -> None:
    """Guards each field's bound: a record cut at any byte raises Malformed, never a
    shorter value, a struct error or a read of what follows."""
    body = _body(record)
    for n in range(len(body)):
        with pytest.raises(Malformed, match="runs past its record"):
            parse(body[:n])


def test_the_bounded_stream_counts_and_refuses() -> None:
    buf = b"xx" + struct.pack("<HI", 7, 9) + b"abc" + b"next record"
    s = BoundedStream(buf, 2, 11)
    assert (s.read2(), s.read4(), s.count, s.remaining) == (7, 9, 6, 3)
    with pytest.raises(Malformed, match="a field of 4 bytes runs past its record"):
        s.read(4)
    assert s.read(3) == b"abc" and s.read(0) == b"" and s.remaining == 0
    with pytest.raises(Malformed, match="runs past"):
        s.read(-1)
    with pytest.raises(Malformed, match="not UTF-8"):
        BoundedStream(struct.pack("<I", 2) + b"\xff\xfe").read_prefixed_string()


def _rec(op: int, body: bytes) -> bytes:
    return struct.pack("<BQ", op, len(body)) + body


def test_walk_yields_each_record_within_its_buffer() -> None:
    buf = _rec(Op.MESSAGE, b"a" * 30) + _rec(Op.SCHEMA, b"") + _rec(0x7F, b"xyz")
    assert list(walk(buf, CHUNK)) == [(Op.MESSAGE, 9, 39), (Op.SCHEMA, 48, 48),
                                      (0x7F, 57, 60)]
    assert list(walk(b"", CHUNK)) == []


@pytest.mark.parametrize(("region", "words"), [
    (CHUNK, ("chunk ends inside a record header",
             "a schema in a chunk declares 5 bytes, past the chunk's end",
             "a record in a chunk has opcode 0")),
    (SUMMARY, ("the summary ends inside a record header",
               "a summary record at byte 109 runs past the summary",
               "a summary record at byte 109 has opcode 0")),
    (RUN, ("the messages at byte 109 end inside a record header",
           "a schema at byte 109 declares 5 bytes, past the messages scanned",
           "a record at byte 109 has opcode 0")),
])
def test_walk_says_where_a_record_does_not_fit(region: Any, words: tuple[str, ...]) -> None:
    """The one iterator words its errors for the buffer it walks, naming the file byte."""
    first = _rec(Op.MESSAGE, b"a" * 22)
    cut_header, past_end, opcode_zero = words
    for tail, expected in ((b"\x03\x00", cut_header),
                           (struct.pack("<BQ", Op.SCHEMA, 5) + b"1234", past_end),
                           (_rec(0, b""), opcode_zero)):
        with pytest.raises(Malformed) as raised:
            list(walk(first + tail, region, base=109 - len(first)))
        assert str(raised.value) == expected


def test_record_names_are_mcaps() -> None:
    assert [record_name(op) for op in (0x01, 0x07, 0x0A, 0x0F)] == [
        "header", "message index", "attachment index", "data end"]
    assert record_name(0x42) == "record" and record_name(0x42, "?") == "?"


def test_the_fast_message_path_reads_what_mcap_reads() -> None:
    msg = Message(channel_id=4, log_time=123, data=b"payload", publish_time=120, sequence=9)
    body = _body(msg)
    assert parse_message(body) == msg
    buf = b"junk" + body + b"more"
    assert parse_message(buf, 4, 4 + len(body)) == msg


def test_chunk_records_keep_schemas_channels_and_messages_only() -> None:
    s, c = RECORDS[2][0], RECORDS[3][0]
    m = Message(channel_id=2, log_time=5, data=b"d", publish_time=5, sequence=0)
    data = b"".join(_rec(op, _body(r)) for op, r in ((Op.SCHEMA, s), (Op.CHANNEL, c),
                                                      (Op.MESSAGE, m)))
    data += _rec(Op.MESSAGE_INDEX, b"ignored")
    assert list(chunk_records(data, Limits())) == [s, c, m]
    with pytest.raises(Malformed, match="a message of 23 bytes is over the limit of 22"):
        list(chunk_records(data, Limits(max_message_bytes=22)))


def test_the_chunk_header_is_read_without_its_data() -> None:
    body = (struct.pack("<QQQI", 10, 20, 300, 0xABC) + struct.pack("<I", 4) + b"zstd"
            + struct.pack("<Q", 5) + b"12345")
    h = parse_chunk_header(body[:48], 1000, len(body))
    assert (h.offset, h.length, h.message_start_time, h.message_end_time, h.uncompressed_size,
            h.uncompressed_crc, h.compression) == (1000, 9 + len(body), 10, 20, 300, 0xABC,
                                                   "zstd")
    assert (h.data_offset, h.data_length) == (1000 + 9 + 44, 5)
    # cut by the end of the file: the header is whole, the record is not
    cut = parse_chunk_header(body[:46], 1000, len(body) - 3, whole=False)
    assert cut.data_length == 5
    with pytest.raises(Malformed, match="does not fill its record"):
        parse_chunk_header(body[:46], 1000, len(body) - 3)
