"""The bounded MCAP parser at the byte: every record, field and chunk is read within its own
bounds, to the byte. Logs are built here by hand in memory (record by record, offsets known),
so each test names the byte that is one too many or one too few:

- a field whose length runs one byte past its record is :class:`Malformed`, never read
  from the next record or silently cut (:mod:`replay.log.mcap_records`);
- a record in a chunk that claims 1-9 bytes more than the chunk holds is refused (the 9 are
  its own opcode and length);
- a record that the end of the file cuts 1-9 bytes short is called truncated, at its own
  offset (:mod:`replay.log.mcap_scan`), and a summary record that runs past the summary is
  refused (:mod:`replay.log.mcap_summary`).
"""

from __future__ import annotations

import io
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from replay.errors import CorruptLogError, TruncatedLogError
from replay.log.catalogue import build_catalogue, load_block
from replay.log.mcap_records import (
    MAGIC,
    Limits,
    Malformed,
    Op,
    chunk_records,
    parse_channel,
    parse_chunk_header,
    parse_chunk_index,
    parse_footer,
    parse_message,
    parse_metadata,
    parse_metadata_index,
    parse_schema,
    parse_statistics,
)
from replay.log.mcap_scan import scan_data
from replay.log.mcap_summary import FOOTER_BYTES, read_footer, read_summary

PATH = Path("hand-made.mcap")
LIMITS = Limits()


# --- building records -------------------------------------------------------------------------
def u16(v: int) -> bytes:
    return struct.pack("<H", v)


def u32(v: int) -> bytes:
    return struct.pack("<I", v)


def u64(v: int) -> bytes:
    return struct.pack("<Q", v)


def text(s: str) -> bytes:
    raw = s.encode()
    return u32(len(raw)) + raw


def str_map(entries: dict[str, str]) -> bytes:
    body = b"".join(text(k) + text(v) for k, v in entries.items())
    return u32(len(body)) + body


def record(op: int, body: bytes) -> bytes:
    return struct.pack("<BQ", op, len(body)) + body


def schema_body(sid: int = 1) -> bytes:
    data = b"string data\n"
    return u16(sid) + text("std_msgs/msg/String") + text("ros2msg") + u32(len(data)) + data


def channel_body(cid: int = 1) -> bytes:
    return (u16(cid) + u16(1) + text("/robot1/ball") + text("cdr")
            + str_map({"offered_qos_profiles": "", "robot": "robot1"}))


def message_body(log_time: int, data: bytes = b"\x00\x01\x00\x00hello") -> bytes:
    return u16(1) + u32(7) + u64(log_time) + u64(log_time) + data


def chunk_body(records: bytes, start_ns: int, end_ns: int) -> bytes:
    """An uncompressed chunk (CRC 0: not checked) holding ``records``."""
    return (u64(start_ns) + u64(end_ns) + u64(len(records)) + u32(0) + text("")
            + u64(len(records)) + records)


def chunk_index_body() -> bytes:
    return (u64(10) + u64(20) + u64(8) + u64(100) + u32(10) + u16(1) + u64(50) + u64(0)
            + text("zstd") + u64(90) + u64(200))


def statistics_body() -> bytes:
    counts = u16(1) + u64(3) + u16(2) + u64(4)
    return (u64(7) + u16(1) + u32(2) + u32(0) + u32(1) + u32(1) + u64(10) + u64(20)
            + u32(len(counts)) + counts)


def metadata_body() -> bytes:
    return text("scenario") + str_map({"name": "scenario2", "seed": "0"})


def metadata_index_body() -> bytes:
    return u64(120) + u64(40) + text("scenario")


FOOTER_BODY = u64(0) + u64(0) + u32(0)


# --- a field one byte past its record ---------------------------------------------------------
PARSERS: dict[str, tuple[Callable[[bytes], Any], bytes]] = {
    "schema": (parse_schema, schema_body()),
    "channel": (parse_channel, channel_body()),
    "message": (parse_message, message_body(5)[:22]),  # the fixed fields alone, no data
    "footer": (parse_footer, FOOTER_BODY),
    "chunk index": (parse_chunk_index, chunk_index_body()),
    "statistics": (parse_statistics, statistics_body()),
    "metadata": (parse_metadata, metadata_body()),
    "metadata index": (parse_metadata_index, metadata_index_body()),
}


@pytest.mark.parametrize("kind", sorted(PARSERS))
def test_each_record_parses_whole_and_refuses_its_last_byte_missing(kind: str) -> None:
    """Guards every record's last field against reading one byte past its record: the whole
    body parses; the body one byte short (its last field, a fixed-width number, a string, a
    byte string or a map, then runs one byte past the end) is Malformed, not a shorter
    value or a struct error."""
    parse, body = PARSERS[kind]
    parse(body)
    with pytest.raises(Malformed, match="runs past its record"):
        parse(body[:-1])


@pytest.mark.parametrize("cut", [1, 2, 5, 9])
def test_a_string_claiming_more_than_the_record_holds_is_refused(cut: int) -> None:
    """Guards a length-prefixed field in the middle of a record: a schema whose name claims
    ``cut`` bytes more than the rest of its record is Malformed."""
    rest = len(schema_body()) - 2 - 4
    body = u16(1) + u32(rest + cut) + schema_body()[6:]
    with pytest.raises(Malformed, match="runs past its record"):
        parse_schema(body)


def test_a_message_in_a_buffer_reads_only_its_own_bytes() -> None:
    """Guards the fast message path (a message parsed in place in a larger buffer): its
    fields end at its own end, not at the buffer's; one byte short of its fixed fields, it
    is Malformed though the next record's bytes follow."""
    first, second = message_body(5, b"abc"), message_body(6, b"defg")
    buf = record(Op.MESSAGE, first) + record(Op.MESSAGE, second)
    msg = parse_message(buf, 9, 9 + len(first))
    assert (msg.log_time, msg.data) == (5, b"abc")
    with pytest.raises(Malformed, match="runs past its record"):
        parse_message(buf, 9, 9 + 21)  # 22 bytes of fixed fields, 21 in the record


def test_a_schema_in_a_chunk_never_reads_the_next_record() -> None:
    """Guards a field at the end of a record inside a chunk: a schema whose data claims one
    byte more than its record holds is Malformed, though the chunk's next record would
    supply that byte."""
    body = schema_body()
    bad = body[:-len(b"string data\n") - 4] + u32(len(b"string data\n") + 1) + b"string data\n"
    data = record(Op.SCHEMA, bad) + record(Op.MESSAGE, message_body(5))
    with pytest.raises(Malformed, match="runs past its record"):
        list(chunk_records(data, LIMITS))


def test_messages_outside_chunks_load_with_their_own_bytes_only() -> None:
    """Guards the run of messages outside chunks (loaded as one block after the scan): each
    message ends at its own record's end, never one byte into the next record."""
    head = MAGIC + record(Op.HEADER, text("ros2") + text("hand"))
    payloads = [b"a", b"bc", b"def"]
    data = head + b"".join(record(Op.MESSAGE, message_body(10 + i, d))
                           for i, d in enumerate(payloads)) + record(Op.DATA_END, u32(0))
    found = scan_data(io.BytesIO(data), PATH, len(data), LIMITS, recover=False)
    [run] = found.blocks
    assert (run.offset, run.messages) == (len(head), 3)
    loaded = load_block(io.BytesIO(data), run, LIMITS)
    assert [(m.log_time, m.data) for m in loaded] == [  # type: ignore[union-attr]
        (10 + i, d) for i, d in enumerate(payloads)]


# --- a record claiming more than its chunk holds ----------------------------------------------
@pytest.mark.parametrize("extra", range(1, 10))
def test_a_message_claiming_more_than_its_chunk_holds_is_refused(extra: int) -> None:
    """Guards the chunk's record bound: the last message of a chunk that claims ``extra``
    (1-9) bytes more than the chunk holds after its header is refused, not returned with
    its data cut short."""
    last = message_body(6, b"0123456789")
    good = record(Op.MESSAGE, message_body(5)) + record(Op.MESSAGE, last)
    assert [m.log_time for m in chunk_records(good, LIMITS)] == [5, 6]  # type: ignore[union-attr]
    bad = good[:-len(last) - 8] + u64(len(last) + extra) + last
    assert len(bad) == len(good)
    with pytest.raises(Malformed, match=f"a message in a chunk declares {len(last) + extra} "
                                        "bytes, past the chunk's end"):
        list(chunk_records(bad, LIMITS))


@pytest.mark.parametrize("extra", [1, 9])
def test_a_chunk_whose_message_runs_past_it_is_a_corrupt_log(extra: int) -> None:
    """Guards the same bound end to end: a whole log whose one uncompressed chunk holds a
    message claiming ``extra`` bytes too many is a corrupt log naming the chunk's byte."""
    last = message_body(6, b"0123456789")
    records = record(Op.MESSAGE, message_body(5)) + record(Op.MESSAGE, last)
    records = records[:-len(last) - 8] + u64(len(last) + extra) + last
    head = MAGIC + record(Op.HEADER, text("ros2") + text("hand")) + record(
        Op.SCHEMA, schema_body()) + record(Op.CHANNEL, channel_body())
    data = head + record(Op.CHUNK, chunk_body(records, 5, 6)) + record(Op.DATA_END, u32(0))
    log = data + record(Op.FOOTER, FOOTER_BODY) + MAGIC
    with pytest.raises(CorruptLogError, match=f"chunk at byte {len(head)}: a message in a "
                                              "chunk declares"):
        build_catalogue(io.BytesIO(log), PATH, len(log), LIMITS, recover=False)


# --- a record cut short by the end of the file ------------------------------------------------
def data_section() -> tuple[bytes, dict[str, tuple[int, int]]]:
    """A log's data section (magic, header, schema, channel, a message outside chunks, an
    uncompressed chunk from 30 ns to 40 ns): its bytes, and each record's (offset, body
    length) by kind."""
    out, where = bytearray(MAGIC), {}
    chunk = chunk_body(record(Op.MESSAGE, message_body(30)) + record(Op.MESSAGE,
                                                                     message_body(40)), 30, 40)
    for kind, op, body in (("header", Op.HEADER, text("ros2") + text("hand")),
                           ("schema", Op.SCHEMA, schema_body()),
                           ("channel", Op.CHANNEL, channel_body()),
                           ("message", Op.MESSAGE, message_body(20)),
                           ("chunk", Op.CHUNK, chunk)):
        where[kind] = (len(out), len(body))
        out += record(op, body)
    return bytes(out), where


def scan(data: bytes, *, recover: bool) -> Any:
    return scan_data(io.BytesIO(data), PATH, len(data), LIMITS, recover=recover)


def test_the_hand_made_data_section_scans_whole() -> None:
    data, where = data_section()
    whole = data + record(Op.DATA_END, u32(0))
    found = scan(whole, recover=False)
    assert found.data_end == len(data) and not found.damage and not found.truncated
    assert [(b.offset, b.messages) for b in found.blocks] == [(where["message"][0], 1),
                                                              (where["chunk"][0], None)]


@pytest.mark.parametrize("short", range(1, 10))
@pytest.mark.parametrize("kind", ["schema", "channel", "message", "chunk"])
def test_a_record_cut_short_by_the_end_of_the_file_is_truncated(kind: str, short: int) -> None:
    """Guards the file-end bound: a log cut ``short`` (1-9) bytes before the end of its
    last record (opcode and length intact) is truncated at that record's own offset, with
    the length it declares, not read short (nor misread as corrupt, nor as ending later)."""
    data, where = data_section()
    offset, length = where[kind]
    cut = data[:offset + 9 + length - short]
    expected = f"a {kind} of {length} bytes runs past the end of the file ({len(cut)} bytes)"
    with pytest.raises(TruncatedLogError) as raised:
        scan(cut, recover=False)
    assert f"(byte {offset}: {expected})" in str(raised.value)
    found = scan(cut, recover=True)
    assert found.truncated
    assert [(d.offset, d.length, d.reason) for d in found.damage] == [
        (offset, len(cut) - offset, expected)]
    if kind == "chunk":  # the chunk's header is whole: its time range is known lost
        assert (found.damage[0].start_ns, found.damage[0].end_ns) == (30, 40)
        assert found.damage[0].chunks == 1
    assert offset not in [b.offset for b in found.blocks]


@pytest.mark.parametrize("short", range(1, 10))
def test_a_chunk_header_cut_short_is_truncated(short: int) -> None:
    """Guards the chunk header's own bound: a chunk record whose fixed fields the file cuts
    ``short`` bytes short is truncated at the chunk, whatever is left of it."""
    data, where = data_section()
    offset, _ = where["chunk"]
    cut = data[:offset + 9 + 8 + 8 + 8 + 4 + 4 - short]  # inside start, end, size, CRC, name
    with pytest.raises(TruncatedLogError, match=f"byte {offset}: a chunk of"):
        scan(cut, recover=False)


def test_the_chunk_header_is_parsed_from_its_own_bytes() -> None:
    """Guards the chunk header's data length against its record: one byte more or less
    than the record holds is Malformed."""
    records = record(Op.MESSAGE, message_body(30))
    body = chunk_body(records, 30, 30)
    header = parse_chunk_header(body, 100, len(body))
    assert (header.data_offset, header.data_length) == (100 + 9 + len(body) - len(records),
                                                        len(records))
    for length in (len(body) - 1, len(body) + 1):
        with pytest.raises(Malformed, match="does not fill its record"):
            parse_chunk_header(body, 100, length)


# --- the summary section ----------------------------------------------------------------------
def log_with_summary(summary_records: bytes) -> bytes:
    """A log with an empty data section and the given summary (summary CRC 0: unchecked)."""
    data = MAGIC + record(Op.HEADER, text("ros2") + text("hand")) + record(Op.DATA_END, u32(0))
    footer = record(Op.FOOTER, u64(len(data)) + u64(0) + u32(0))
    return data + summary_records + footer + MAGIC


def summary_of(log: bytes) -> Any:
    f = io.BytesIO(log)
    return read_summary(f, len(log), read_footer(f, len(log)), LIMITS)


@pytest.mark.parametrize("extra", range(1, 10))
def test_a_summary_record_running_past_the_summary_is_refused(extra: int) -> None:
    """Guards the summary's record bound: a summary whose last record claims ``extra``
    (1-9) bytes more than the summary holds is Malformed, not parsed from the bytes left."""
    stats, index = record(Op.STATISTICS, statistics_body()), record(
        Op.METADATA_INDEX, metadata_index_body())
    summary = summary_of(log_with_summary(index + stats))
    assert summary.statistics is not None and summary.statistics.message_count == 7
    assert summary.statistics.channel_message_counts == {1: 3, 2: 4}
    long = index + stats[:1] + u64(len(statistics_body()) + extra) + stats[9:]
    with pytest.raises(Malformed, match="runs past the summary"):
        summary_of(log_with_summary(long))


def test_the_footer_is_read_from_the_files_last_bytes() -> None:
    """Guards the footer's bounds: the footer record and closing magic are the last
    FOOTER_BYTES; one byte more or less of footer body is refused."""
    log = log_with_summary(b"")
    assert read_footer(io.BytesIO(log), len(log)).summary_start == len(log) - FOOTER_BYTES
    for body in (FOOTER_BODY[:-1], FOOTER_BODY + b"\x00"):
        bad = log[:-FOOTER_BYTES] + record(Op.FOOTER, body) + MAGIC
        with pytest.raises(Malformed, match="no footer record"):
            read_footer(io.BytesIO(bad), len(bad))
