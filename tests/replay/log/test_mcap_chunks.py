"""replay.log.mcap_chunks: chunks decompressed within bounds, and the decodable prefix of a
cut or damaged chunk salvaged."""

from __future__ import annotations

import random
import struct
import zlib

import lz4.frame
import pytest
import zstandard
from fuzzing_logs import zstd_block_headers

from replay.log.mcap_chunks import decompress, salvage
from replay.log.mcap_records import ChunkHeader, Limits, Malformed, Op

LIMITS = Limits()


def _message(t: int, size: int, rng: random.Random) -> bytes:
    body = struct.pack("<HIQQ", 1, t, t, t) + rng.randbytes(size)
    return struct.pack("<BQ", Op.MESSAGE, len(body)) + body


def _records(n: int = 40, size: int = 3000) -> bytes:
    """``n`` messages (log times 0..n-1) of ``size`` bytes of noise each, uncompressed."""
    rng = random.Random(3)
    return b"".join(_message(t, size, rng) for t in range(n))


def _compress(raw: bytes, how: str) -> bytes:
    if how == "zstd":
        return zstandard.ZstdCompressor().compress(raw)
    if how == "lz4":
        return bytes(lz4.frame.compress(raw, block_size=lz4.frame.BLOCKSIZE_MAX64KB))
    return raw


def _chunk(raw: bytes, how: str, data: bytes, *, size: int | None = None,
           crc: int | None = None, start: int = 0, end: int = 10**9) -> ChunkHeader:
    return ChunkHeader(0, 9 + 40 + len(data), start, end, len(raw) if size is None else size,
                       zlib.crc32(raw) if crc is None else crc, how, 49, len(data))


@pytest.mark.parametrize("n", [40, 1200])  # 120 KB, and 3.6 MB: several decoder steps
@pytest.mark.parametrize("how", ["", "zstd", "lz4"])
def test_a_whole_chunk_decompresses_and_is_crc_checked(how: str, n: int) -> None:
    raw = _records(n)
    data = _compress(raw, how)
    assert decompress(_chunk(raw, how, data), data, LIMITS) == raw
    with pytest.raises(Malformed, match="CRC mismatch"):
        decompress(_chunk(raw, how, data, crc=1), data, LIMITS)


@pytest.mark.parametrize("how", ["", "zstd", "lz4"])
def test_decompression_never_passes_the_declared_size(how: str) -> None:
    """Guards the bomb bound: data that inflates past the size its header declares is
    refused, whatever it would inflate to; and one that declares over the limit is refused
    before anything is decoded."""
    raw = bytes(4 << 20)
    data = _compress(raw, how)
    with pytest.raises(Malformed, match="more than the 1000 bytes its header declares"):
        decompress(_chunk(raw, how, data, size=1000), data, LIMITS)
    with pytest.raises(Malformed, match="over the limit"):
        decompress(_chunk(raw, how, data), data, Limits(max_chunk_bytes=1 << 20))
    short = _chunk(raw, how, data, size=len(raw) + 1)
    with pytest.raises(Malformed, match=f"decompresses to {len(raw)} bytes"):
        decompress(short, data, LIMITS)


def test_an_unknown_compression_is_refused() -> None:
    raw = _records(2)
    with pytest.raises(Malformed, match="unknown chunk compression 'bz2'"):
        decompress(_chunk(raw, "bz2", raw), raw, LIMITS)


def _times(kept: list[object]) -> list[int]:
    return [r.log_time for r in kept]  # type: ignore[attr-defined]


@pytest.mark.parametrize("how", ["", "zstd", "lz4"])
def test_a_cut_chunk_keeps_the_whole_records_before_the_cut(how: str) -> None:
    """Guards the salvage bound: of a chunk cut anywhere, the messages kept are exactly the
    whole records the decoder can give for the bytes before the cut, in order."""
    raw = _records()
    data = _compress(raw, how)
    chunk = _chunk(raw, how, data)
    for cut in range(0, len(data), 997):
        kept = salvage(chunk, data[:cut], LIMITS, cut=True)
        decodable = (zstandard.ZstdDecompressor().decompressobj().decompress(data[:cut])
                     if how == "zstd" else lz4.frame.LZ4FrameDecompressor().decompress(
                         data[:cut]) if how == "lz4" else data[:cut])
        assert kept.decoded_bytes == len(decodable)
        whole = len(decodable) // (9 + 22 + 3000)
        assert _times(kept.records) == list(range(whole)), cut
        assert kept.reason == "the end of the file cuts it"
    assert _times(salvage(chunk, data, LIMITS, cut=False).records) == list(range(40))
    assert salvage(chunk, data, LIMITS, cut=False).reason == ""


@pytest.mark.parametrize("how", ["zstd", "lz4"])
def test_a_chunk_whose_data_breaks_keeps_what_precedes_the_break(how: str) -> None:
    """Data that stops decoding two thirds in (zstd: a block header of a reserved type;
    LZ4: noise from there on): the records decoded before the break are kept (within one
    small step of it), in order, and none after."""
    raw = _records(150)
    data = bytearray(_compress(raw, how))
    if how == "zstd":
        blocks = zstd_block_headers(bytes(data))
        at = blocks[len(blocks) * 2 // 3]
        data[at] |= 0b110
    else:
        at = len(data) * 2 // 3
        data[at:] = random.Random(1).randbytes(len(data) - at)
    kept = salvage(_chunk(raw, how, bytes(data)), bytes(data), LIMITS, cut=False)
    assert kept.reason and kept.reason != "the end of the file cuts it"
    assert 0 < len(kept.records) < 150
    assert _times(kept.records) == list(range(len(kept.records)))
    assert kept.decoded_bytes >= len(raw) // 2 - (1 << 17)


def test_salvage_trusts_no_byte_of_a_chunk_that_fails_its_crc() -> None:
    raw = _records()
    bad = bytearray(raw)
    bad[-10] ^= 1
    kept = salvage(_chunk(raw, "", bytes(bad)), bytes(bad), LIMITS, cut=False)
    assert kept.records == [] and "CRC does not match" in kept.reason


def test_salvage_stops_at_a_record_that_does_not_parse_or_fit() -> None:
    raw = _records(10)
    one = 9 + 22 + 3000
    broken = raw[:3 * one] + struct.pack("<BQ", Op.MESSAGE, 10**9) + raw[3 * one + 9:]
    kept = salvage(_chunk(raw, "", broken, crc=0), broken, LIMITS, cut=False)
    assert _times(kept.records) == [0, 1, 2]
    assert kept.reason.startswith("a record does not parse (a message in a chunk declares")
    late = salvage(_chunk(raw, "", raw, end=3), raw, LIMITS, cut=False)
    assert _times(late.records) == [0, 1, 2, 3]
    assert late.reason == "a message lies outside the chunk's time range"


def test_salvage_refuses_over_the_limit() -> None:
    raw = _records(4)
    kept = salvage(_chunk(raw, "", raw), raw, Limits(max_chunk_bytes=100), cut=True)
    assert kept.records == [] and "over the limit" in kept.reason
