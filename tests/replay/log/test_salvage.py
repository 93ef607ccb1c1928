"""``--recover`` salvages the decodable prefix of a cut or damaged chunk: every message an
independent reader finds before the cut, and nothing after it; a recovery that finds nothing
says why in terms of the log."""

from __future__ import annotations

import io
import json
import random
import struct
from pathlib import Path

import pytest
from fuzzing import GOLDEN, messages_before_cut, read_raw, records, write_raw
from fuzzing_logs import zstd_block_headers
from mcap.data_stream import ReadDataStream
from mcap.records import Chunk, Message
from mcap.stream_reader import breakup_chunk
from mcap.writer import CompressionType

from replay.cli import main
from replay.errors import CorruptLogError, MissingPosesError, NoFramesError, TruncatedLogError
from replay.info.cli import main as info_main
from replay.log.catalogue import build_catalogue, load_block
from replay.log.mcap_records import Limits
from replay.options import ReplayOptions
from replay.runner import replay

LIMITS = Limits()
Found = list[tuple[int, int, int, bytes]]
"""(channel id, sequence, log time, data) of each message, in file order."""


def _found(messages: list[Message]) -> Found:
    return [(m.channel_id, m.sequence, m.log_time, m.data) for m in messages]


def reference(log: bytes, cut: int) -> Found:
    """The messages an independent reader finds in ``log[:cut]``
    (:func:`fuzzing.messages_before_cut`: mcap's own reader for the chunks before the cut,
    the zstandard / lz4 streaming decoders for the one it falls in)."""
    return _found(messages_before_cut(log, cut)[0])


def recovered(log: bytes) -> Found:
    """The messages our reader recovers from ``log``."""
    f = io.BytesIO(log)
    cat = build_catalogue(f, Path("cut.mcap"), len(log), LIMITS, recover=True)
    return _found([m for b in cat.blocks for m in load_block(f, b, LIMITS)
                   if isinstance(m, Message)])


LAYOUTS = {
    "recorder": {},  # the golden log as recorded: zstd, the recorder's chunks
    "zstd 64 KiB": {"compression": CompressionType.ZSTD, "chunk_size": 64 * 1024},
    "lz4 64 KiB": {"compression": CompressionType.LZ4, "chunk_size": 64 * 1024},
    "uncompressed 64 KiB": {"compression": CompressionType.NONE, "chunk_size": 64 * 1024},
    "unchunked": {"use_chunking": False},
}


@pytest.fixture(scope="module", params=sorted(LAYOUTS))
def rolling(request: pytest.FixtureRequest) -> bytes:
    data = (GOLDEN / "rolling.mcap").read_bytes()
    if not LAYOUTS[request.param]:
        return data
    return write_raw(read_raw(GOLDEN / "rolling.mcap"), **LAYOUTS[request.param])


def _cuts(log: bytes) -> list[int]:
    """Offsets to cut at: 40 anywhere (seeded), and around every record's start and end."""
    rng = random.Random(7)
    cuts = {rng.randrange(9, len(log)) for _ in range(40)}
    for r in records(log):
        if r.region == "data" and r.op in (0x05, 0x06):
            for at in (r.offset, r.offset + 9 + r.length):
                cuts.update(at + d for d in (-9, -1, 0, 1, 9, 64))
    return sorted(c for c in cuts if 9 <= c < len(log))


def test_a_cut_anywhere_recovers_every_message_before_it(rolling: bytes) -> None:
    """Guards salvage against losing or inventing a message: cut at any byte, the log
    recovers exactly the messages an independent reader finds before the cut, in order."""
    cuts = _cuts(rolling)
    total = len(reference(rolling, len(rolling)))
    assert total > 50 and len(cuts) > 60
    kept = []
    for cut in cuts:
        expected = reference(rolling, cut)
        assert recovered(rolling[:cut]) == expected, f"cut at byte {cut}"
        kept.append(len(expected))
    assert kept == sorted(kept) and 0 < max(kept) <= total  # more bytes, never fewer messages


def test_scenario1_cut_at_60_percent_replays_the_frames_before_the_cut(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The golden scenario1 log is one chunk; cut at 60% it used to give 0 frames and "no
    image topics match". Now the frames whose bytes decode before the cut replay as they do
    from the whole log, and the salvage is reported."""
    data = (GOLDEN / "scenario1.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 6 // 10])
    with pytest.raises(TruncatedLogError):
        replay(cut)
    full = tmp_path / "full.json"
    assert main([str(GOLDEN / "scenario1.mcap"), "--out", str(full), "-q"]) == 0
    out = tmp_path / "cut.json"
    assert main([str(cut), "--recover", "--out", str(out), "--no-progress"]) == 0
    err = capsys.readouterr().out
    got, whole = json.loads(out.read_text()), json.loads(full.read_text())
    assert 1 <= len(got["frames"]) < len(whole["frames"])
    by_key = {(f["robot"], f["stamp_ns"]): f for f in whole["frames"]}
    for frame in got["frames"]:
        assert frame["detection"] == by_key[(frame["robot"], frame["stamp_ns"])]["detection"]
    [kept] = got["log"]["recovered"]["salvaged"]
    assert kept["offset"] == records(data)[4].offset and kept["messages"] == len(
        reference(data, len(data) * 6 // 10))
    assert kept["end_s"] >= max(f["t_s"] for f in got["frames"])
    assert got["log"]["recovered"]["lost"][0]["start_s"] == kept["end_s"]
    assert f"salvaged from the chunk at byte {kept['offset']}: {kept['messages']} message(s)" in err


def test_a_recovery_that_finds_nothing_says_why(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """A log cut inside the first zstd block of its only chunk holds no whole record: the
    error names the chunk and the cut, not a topic mismatch; ``dsp-info --check`` says the
    same, on its report and on its one error line."""
    data = (GOLDEN / "scenario1.mcap").read_bytes()
    chunk = next(r for r in records(data) if r.op == 0x06)
    at = chunk.offset + 9 + 2000
    cut = tmp_path / "early.mcap"
    cut.write_bytes(data[:at])
    with pytest.raises(NoFramesError, match=rf"nothing is recoverable: its only chunk \(at byte "
                                            rf"{chunk.offset}\) is cut at byte {at}; nothing "
                                            "before the cut decodes"):
        replay(cut, ReplayOptions(recover=True))
    assert info_main([str(cut), "--check"]) == 1
    captured = capsys.readouterr()
    why = (f"nothing is recoverable: its only chunk (at byte {chunk.offset}) is cut at byte "
           f"{at}; nothing before the cut decodes")
    assert f"recover:     {why}" in captured.out
    assert why in captured.err and captured.err.count("\n") == 1
    assert "topic" not in captured.err


def _damage_middle_chunk(log: bytes) -> tuple[bytes, int, int]:
    """``log`` with the header of the last zstd block of a middle chunk damaged (reserved
    block type: the decoder stops there), the record intact: (bytes, the chunk's offset,
    messages in it)."""
    chunks = [r for r in records(log) if r.op == 0x06]
    victim = chunks[len(chunks) // 2]
    body = log[victim.offset + 9:victim.offset + 9 + victim.length]
    start = victim.offset + 9 + 40 + struct.unpack_from("<I", body, 28)[0]
    blocks = zstd_block_headers(log[start:victim.offset + 9 + victim.length])
    assert len(blocks) >= 2
    buf = bytearray(log)
    buf[start + blocks[-1]] |= 0b110  # block type 3: reserved, "corrupted block"
    whole = Chunk.read(ReadDataStream(io.BytesIO(body)))
    count = sum(isinstance(rec, Message) for rec in breakup_chunk(whole))
    return bytes(buf), victim.offset, count


def test_a_damaged_chunk_keeps_what_precedes_the_damage(tmp_path: Path) -> None:
    """A chunk in the middle of a log whose data breaks half way: strict reading refuses
    the log; --recover keeps the chunk's messages before the damage, every other chunk
    whole, and counts the messages lost exactly (the message index says how many)."""
    log = write_raw(read_raw(GOLDEN / "rolling.mcap"), compression=CompressionType.ZSTD,
                    chunk_size=512 * 1024)
    bad, offset, in_chunk = _damage_middle_chunk(log)
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bad)
    with pytest.raises(CorruptLogError, match=f"at byte {offset}: zstd"):
        replay(path)
    f = io.BytesIO(bad)
    cat = build_catalogue(f, path, len(bad), LIMITS, recover=True)
    [kept] = cat.salvaged
    assert kept.offset == offset and 0 < kept.messages < in_chunk
    [lost] = cat.damage
    assert lost.offset == offset and lost.messages == in_chunk - kept.messages
    assert lost.start_ns == kept.end_ns
    everything = reference(log, len(log))
    found = recovered(bad)
    assert len(found) == len(everything) - lost.messages
    assert set(found) <= set(everything)  # nothing invented
    summary = replay(path, ReplayOptions(recover=True))
    assert summary.recovered is not None and summary.recovered["lost_messages"] == lost.messages


def test_a_chunk_failing_its_crc_keeps_nothing(tmp_path: Path) -> None:
    """Guards salvage against trusting damaged bytes: a chunk that decodes whole but fails
    its CRC cannot tell which bytes are wrong, so none of it is kept."""
    log = write_raw(read_raw(GOLDEN / "rolling.mcap"), compression=CompressionType.NONE,
                    chunk_size=64 * 1024)
    chunks = [r for r in records(log) if r.op == 0x06]
    victim = chunks[1]
    buf = bytearray(log)
    buf[victim.offset + 9 + victim.length - 5] ^= 0x01  # the last message's data
    f = io.BytesIO(bytes(buf))
    cat = build_catalogue(f, Path("crc.mcap"), len(buf), LIMITS, recover=True)
    [kept] = cat.salvaged
    assert kept.messages == 0 and "CRC" in kept.reason
    assert [d.offset for d in cat.damage] == [victim.offset]


def test_dsp_info_check_lists_the_salvage(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    data = (GOLDEN / "scenario1.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 6 // 10])
    assert info_main([str(cut), "--check"]) == 1
    out = capsys.readouterr().out
    found = reference(data, len(data) * 6 // 10)
    n = len(found)
    first, last = min(m[2] for m in found) / 1e9, max(m[2] for m in found) / 1e9
    assert f"salvaged from the chunk at byte {records(data)[4].offset}: {n} message(s)" in out
    assert "the rest is lost: the end of the file cuts it" in out
    assert f"recover:     --recover keeps {n} message(s), sim time {first:.3f}..{last:.3f} s" in out


def test_a_robot_the_damage_left_without_poses_is_left_out(tmp_path: Path) -> None:
    """Recovering a damaged log whose readable part has a robot's images but no pose topic
    for it: the other robots replay, and the report says which robot was left out (an
    intact log without that pose topic stays an error)."""
    raw = read_raw(GOLDEN / "rolling.mcap")
    gone = next(cid for cid, c in raw.channels.items() if c[0] == "/robot3/pose")
    del raw.channels[gone]
    raw.messages = [m for m in raw.messages if m[0] != gone]
    log = write_raw(raw, compression=CompressionType.ZSTD, chunk_size=64 * 1024)
    path = tmp_path / "cut.mcap"
    path.write_bytes(log[: len(log) * 2 // 3])
    summary = replay(path, ReplayOptions(recover=True))
    assert summary.robots == ("robot1", "robot2") and summary.frames > 0
    assert summary.recovered is not None and any(
        "for robot3: their images are left out" in p for p in summary.recovered["problems"])
    whole = tmp_path / "whole.mcap"
    whole.write_bytes(log)
    with pytest.raises(MissingPosesError, match="robot3"):
        replay(whole, ReplayOptions(recover=True))
