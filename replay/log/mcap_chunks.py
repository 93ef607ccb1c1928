"""A chunk's records: its data decompressed (zstd, LZ4 or none) as a stream that never
inflates past the size its header declares, nor past the limit, then CRC-checked.

:func:`decompress` is the strict path: the whole chunk or :class:`Malformed`.
:func:`salvage` is ``--recover``'s: the records of the decodable prefix of a chunk that the
end of the file cuts, or whose compressed data breaks part way (zstd and LZ4 both decode
block by block, so what comes before the cut or the damage is intact), up to the first
record that is incomplete or does not parse; :class:`Salvage` says what was kept and why
the rest was not.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

from mcap.records import Channel, Message, Schema

from replay.log.mcap_records import ChunkHeader, Limits, Malformed, chunk_records

__all__ = ["COMPRESSIONS", "CUT", "Salvage", "decompress", "salvage"]

COMPRESSIONS = ("", "zstd", "lz4")
CUT = "the end of the file cuts it"
"""Why the rest of a cut chunk is lost."""
_STEP = 1 << 20
"""Bytes decompressed (and, for LZ4, fed) per call."""
_SMALL_STEP = 1 << 13
"""The same where the data breaks part way: only the call that breaks loses its bytes."""


def _check_size(chunk: ChunkHeader, limits: Limits) -> None:
    if chunk.uncompressed_size > limits.max_chunk_bytes:
        raise Malformed(f"chunk declares {chunk.uncompressed_size} bytes uncompressed, over "
                        f"the limit of {limits.max_chunk_bytes} (raise --max-chunk-mib)")
    if chunk.compression not in COMPRESSIONS:
        raise Malformed(f"unknown chunk compression {chunk.compression[:20]!r}")


def _inflate(chunk: ChunkHeader, data: bytes, step: int = _STEP) -> tuple[bytes, str]:
    """At most one byte more than the header declares, decoded from ``data`` as a stream
    ``step`` bytes at a time: the bytes decoded, and why decoding stopped early ("" when it
    did not break)."""
    size = chunk.uncompressed_size
    if chunk.compression == "":
        return data[:size + 1], ""
    if chunk.compression == "zstd":
        return _unzstd(data, size + 1, step)
    return _unlz4(data, size + 1, step)


def decompress(chunk: ChunkHeader, data: bytes, limits: Limits) -> bytes:
    """A chunk's records, uncompressed and CRC-checked; never more than the header declares
    (and the header never more than the limit)."""
    _check_size(chunk, limits)
    size = chunk.uncompressed_size
    out, broke = _inflate(chunk, data)
    if broke:
        raise Malformed(broke)
    if len(out) > size:
        raise Malformed(f"chunk decompresses to more than the {size} bytes its header declares")
    if len(out) < size:
        raise Malformed(f"chunk decompresses to {len(out)} bytes, its header declares {size}")
    if chunk.uncompressed_crc != 0 and zlib.crc32(out) != chunk.uncompressed_crc:
        raise Malformed("chunk CRC mismatch")
    return out


def _unzstd(data: bytes, most: int, step: int) -> tuple[bytes, str]:
    import zstandard

    parts: list[bytes] = []
    total = 0
    try:
        reader = zstandard.ZstdDecompressor().stream_reader(data)
        while total < most:
            block = reader.read(min(step, most - total))
            if not block:
                break
            parts.append(block)
            total += len(block)
    except zstandard.ZstdError as err:
        return b"".join(parts), f"zstd: {err}"
    return b"".join(parts), ""


def _unlz4(data: bytes, most: int, step: int) -> tuple[bytes, str]:
    import lz4.frame

    parts: list[bytes] = []
    total, fed, idle = 0, 0, 0
    d = lz4.frame.LZ4FrameDecompressor()
    try:
        while total < most and not d.eof and idle < 2:
            feed = b""
            if d.needs_input:
                feed = data[fed:fed + step]
                if not feed:
                    break  # all fed: what is left is a block the end cuts
                fed += len(feed)
            block = bytes(d.decompress(feed, max_length=min(step, most - total)))
            idle = idle + 1 if not block and not feed else 0
            parts.append(block)
            total += len(block)
    except RuntimeError as err:
        return b"".join(parts), f"lz4: {err}"
    return b"".join(parts), ""


@dataclass(frozen=True)
class Salvage:
    """What :func:`salvage` kept of a chunk."""

    records: list[Schema | Channel | Message]
    """The whole records before the first incomplete or damaged one, in order."""
    decoded_bytes: int
    """Uncompressed bytes decoded (of the header's ``uncompressed_size``)."""
    reason: str
    """Why the rest is lost, in words ("" when nothing is)."""

    @property
    def messages(self) -> list[Message]:
        return [r for r in self.records if isinstance(r, Message)]


def salvage(chunk: ChunkHeader, data: bytes, limits: Limits, *, cut: bool) -> Salvage:
    """The records of the decodable prefix of ``data``, a chunk's compressed bytes (``cut``:
    the end of the file cuts them; else they are whole but damaged), up to the first record
    that is incomplete, does not parse or lies outside the chunk's time range. Never
    inflates past the declared size or the limit. A chunk that decodes whole but fails its
    CRC keeps nothing: which of its bytes are damaged cannot be told."""
    try:
        _check_size(chunk, limits)
    except Malformed as err:
        return Salvage([], 0, str(err))
    size = chunk.uncompressed_size
    # in one call, the decoder hands over what it holds of the block the end cuts; where
    # the data breaks, small steps keep what precedes the break
    raw, broke = _inflate(chunk, data, size + 1)
    if broke:
        raw, broke = _inflate(chunk, data, _SMALL_STEP)
    if len(raw) > size:
        return Salvage([], len(raw), "it decompresses to more than the "
                       f"{size} bytes its header declares")
    if len(raw) == size and chunk.uncompressed_crc != 0 and (
            zlib.crc32(raw) != chunk.uncompressed_crc):
        return Salvage([], size, "its CRC does not match, so no part of it can be trusted")
    why = ""
    if broke:
        why = f"its data stops decoding after {len(raw)} of {size} bytes ({broke})"
    elif len(raw) < size:
        why = (CUT if cut else
               f"it decodes to {len(raw)} bytes, its header declares {size}")
    records: list[Schema | Channel | Message] = []
    try:
        for rec in chunk_records(raw, limits):
            if isinstance(rec, Message) and not (
                    chunk.message_start_time <= rec.log_time <= chunk.message_end_time):
                why = why or "a message lies outside the chunk's time range"
                break
            records.append(rec)
    except Malformed as err:
        if not why:  # else the record is incomplete because the data stops: said already
            why = f"a record does not parse ({err})"
    return Salvage(records, len(raw), why)
