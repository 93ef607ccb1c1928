"""Hostile logs end in one line naming the file and the problem, or in a counted skip of the
bad message; memory stays bounded; the summary and CRCs are checked; --recover says exactly
what it lost."""

from __future__ import annotations

import random
import struct
import time
from dataclasses import replace
from pathlib import Path

import pytest
from fuzzing import (
    GOLDEN,
    bomb_image,
    m_pose,
    m_summary,
    m_zstd_bomb,
    peak_rss_bytes,
    read_raw,
    records,
    reset_peak_rss,
    seed_log,
    write_raw,
)
from mcap.writer import CompressionType

from dsp.errors import DspError, UsageError
from estimator.constants import NS_PER_S as NS
from replay.cli import main
from replay.errors import (
    CorruptLogError,
    NoFramesError,
    NotMcapError,
    SchemaError,
    TruncatedLogError,
)
from replay.log import (
    ImageMessage,
    LogReader,
    PoseMessage,
    RecoveryLoss,
    decode_image,
    image_size,
)
from replay.log.mcap_scan import Damage
from replay.options import ReplayOptions
from replay.runner import replay
from replay.sync import DelayLine, History


@pytest.fixture(scope="module")
def seed() -> bytes:
    return seed_log("scenario2")


def _write(tmp_path: Path, data: bytes, name: str = "bad.mcap") -> Path:
    path = tmp_path / name
    path.write_bytes(data)
    return path


def _one_line(path: Path, capsys: pytest.CaptureFixture[str], *args: str) -> str:
    code = main([str(path), "--no-progress", *args])
    err = capsys.readouterr().err
    assert code != 0 and "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0], err
    return lines[0]


@pytest.mark.parametrize("data", [b"", b"\x89MCAP0\r\n", b"\x89MCAP0\r\n\x01",
                                  b"\x89MCAP0\r\n" * 2])
def test_tiny_files(tmp_path: Path, data: bytes, capsys: pytest.CaptureFixture[str]) -> None:
    _one_line(_write(tmp_path, data), capsys)


@pytest.mark.parametrize("value", [1 << 40, 1 << 48, (1 << 64) - 1, 1 << 63])
def test_hostile_lengths_are_refused_before_allocation(
        tmp_path: Path, seed: bytes, value: int, capsys: pytest.CaptureFixture[str]) -> None:
    for rec in records(seed)[:6]:
        buf = bytearray(seed)
        struct.pack_into("<Q", buf, rec.offset + 1, value)
        line = _one_line(_write(tmp_path, bytes(buf)), capsys)
        assert "byte" in line


def test_zstd_bomb_is_refused_within_bounded_memory(tmp_path: Path, seed: bytes) -> None:
    rng = random.Random(0)
    for _ in range(4):
        data, what, _where = m_zstd_bomb(seed, rng)
        reset_peak_rss()
        with pytest.raises(CorruptLogError, match=r"byte|chunk"):
            replay(_write(tmp_path, data))
        assert peak_rss_bytes() < 1 << 30, what


def test_summary_disagreeing_with_the_data_is_an_error(tmp_path: Path) -> None:
    seed = seed_log("scenario2", compression=CompressionType.LZ4, chunk_size=32 * 1024)
    seen = set()
    for i in range(40):
        data, what, _ = m_summary(seed, random.Random(i))
        seen.add(what)
        with pytest.raises(CorruptLogError, match="summary disagrees"):
            replay(_write(tmp_path, data))
    assert len(seen) == 4  # duplicated / dropped chunk index, topic, metadata index


def test_summary_crc_is_checked(tmp_path: Path, seed: bytes) -> None:
    footer = next(r for r in records(seed) if r.op == 0x02)
    start = struct.unpack_from("<Q", seed, footer.offset + 9)[0]
    buf = bytearray(seed)
    buf[start + 20] ^= 1
    with pytest.raises(CorruptLogError, match="summary CRC"):
        replay(_write(tmp_path, bytes(buf)))


def test_chunk_crc_is_checked(tmp_path: Path, seed: bytes) -> None:
    chunk = next(r for r in records(seed) if r.op == 0x06)
    buf = bytearray(seed)
    struct.pack_into("<I", buf, chunk.offset + 9 + 24, 12345)
    with pytest.raises(CorruptLogError, match="CRC"):
        replay(_write(tmp_path, bytes(buf)))


def test_damaged_schema_text_is_one_line(tmp_path: Path, seed: bytes) -> None:
    raw = read_raw(GOLDEN / "scenario2.mcap")
    for sid, (name, enc, text) in raw.schemas.items():
        if name == "sensor_msgs/msg/CompressedImage":
            raw.schemas[sid] = (name, enc, text.replace(b"uint8[] data", b"uint8[] da-ta"))
    with pytest.raises(SchemaError, match=r"CompressedImage|image"):
        replay(_write(tmp_path, write_raw(raw)))


def test_bad_poses_are_counted_not_used(tmp_path: Path, seed: bytes,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    data, _what, _ = m_pose(seed, random.Random(3))
    path = _write(tmp_path, data)
    with LogReader(path) as log:
        poses = [m for m in log.messages() if isinstance(m, PoseMessage)]
        assert log.bad_messages and all(k.startswith("bad pose") for k in log.bad_messages)
    assert all(abs(p.x_m) < 1e9 and abs(p.qw) < 1e9 for p in poses)
    assert main([str(path), "--no-progress"]) == 0
    assert "bad pose" in capsys.readouterr().err


def test_empty_image_data_is_a_counted_skip(tmp_path: Path, seed: bytes) -> None:
    raw = read_raw(GOLDEN / "scenario2.mcap")
    image_channels = {cid for cid, ch in raw.channels.items() if ch[0].endswith("compressed")}
    first = next(i for i, m in enumerate(raw.messages) if m[0] in image_channels)
    cid, seq, lt, pt, data = raw.messages[first]
    pos = data.rindex(b"png") + 4  # format "png\0", aligned: the data length follows
    pos = (pos + 3) & ~3
    raw.messages[first] = (cid, seq, lt, pt, data[:pos] + struct.pack("<I", 0))
    path = _write(tmp_path, write_raw(raw))
    summary = replay(path)
    assert summary.undecodable_messages == 1 and summary.frames == 8


@pytest.mark.parametrize("index", range(6))
def test_image_bombs_are_refused_from_the_header(index: int) -> None:
    data = bomb_image(random.Random(index))
    fmt, width, height = image_size(data) or ("", 0, 0)
    assert width * height > 40_000_000, fmt
    reset_peak_rss()
    assert decode_image(ImageMessage("robot1", 0, 0, fmt, data)) is None
    assert peak_rss_bytes() < 1 << 30


def test_look_ahead_is_bounded() -> None:
    line = DelayLine(lookahead_ns=10**8, max_images=8)
    released = 0
    for i in range(1000):  # stamped far in the future: never "ready" by time
        line.push(ImageMessage("robot1", 10**18 + i, i, "png", b"x" * 10))
        released += len(list(line.ready(i)))
        assert len(line) <= 8
    assert released == 1000 - 8


def test_pose_history_takes_descending_stamps_fast() -> None:
    history: History[PoseMessage] = History(horizon_ns=10**18)
    t0 = time.perf_counter()
    for i in range(60_000):
        history.add(PoseMessage("robot1", 60_000 - i, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    assert time.perf_counter() - t0 < 5.0
    before, after = history.neighbours(59_999)
    assert before is not None and after is not None and before.stamp_ns == 59_999


def _small_chunk_rolling(tmp_path: Path) -> Path:
    raw = read_raw(GOLDEN / "rolling.mcap")
    return _write(tmp_path, write_raw(raw, compression=CompressionType.ZSTD,
                                      chunk_size=64 * 1024), "rolling-small.mcap")


def test_recover_reports_nothing_for_an_intact_log(tmp_path: Path) -> None:
    path = _small_chunk_rolling(tmp_path)
    with LogReader(path, recover=True) as log:
        assert log.loss.nothing_lost and log.loss.lost_bytes == 0
    assert replay(path, ReplayOptions(recover=True)).recovered["lost"] == []  # type: ignore[index]


def test_recover_half_a_log_written_in_small_chunks(tmp_path: Path) -> None:
    path = _small_chunk_rolling(tmp_path)
    full = replay(path).frames
    data = path.read_bytes()
    cut = _write(tmp_path, data[: len(data) // 2], "cut.mcap")
    with pytest.raises(TruncatedLogError, match="--recover"):
        replay(cut)
    summary = replay(cut, ReplayOptions(recover=True))
    assert summary.frames >= 0.35 * full
    rec = summary.recovered
    assert rec is not None and rec["truncated"] and rec["bad_chunks"] == 1
    assert rec["lost"][0]["start_s"] is not None


def test_lost_messages_are_unknown_when_any_lost_span_has_no_count(tmp_path: Path) -> None:
    """Guards the lost-message total: a span whose count is unknown (a chunk cut by the end
    of the file) makes the total unknown, not that span counted as 0 messages."""
    known = Damage(100, 50, "a damaged chunk", 0, NS, messages=3, chunks=1)
    cut = Damage(500, 500, "the log is cut", None, None, messages=None, chunks=1)
    counted = RecoveryLoss.from_damage(1000, [known, replace(known, offset=200)], [], NS)
    assert counted.lost_messages == 6
    assert "2 chunk(s), 6 message(s)" in counted.describe()[0]
    unknown = RecoveryLoss.from_damage(1000, [known, cut], [], NS)
    assert unknown.lost_messages is None and unknown.to_dict()["lost_messages"] is None
    assert "2 chunk(s), an unknown number of message(s); the log is cut short" in (
        unknown.describe()[0])
    # a real log cut in the middle of a chunk: the cut chunk's messages are not counted
    path = _small_chunk_rolling(tmp_path)
    data = path.read_bytes()
    with LogReader(_write(tmp_path, data[: len(data) // 2], "cut.mcap"), recover=True) as log:
        assert log.loss.truncated and log.loss.spans[-1].messages is None
        assert log.loss.lost_messages is None


def test_recover_skips_a_damaged_chunk_and_says_when(tmp_path: Path) -> None:
    path = _small_chunk_rolling(tmp_path)
    data = bytearray(path.read_bytes())
    chunks = [r for r in records(bytes(data)) if r.op == 0x06]
    victim = chunks[len(chunks) // 2]
    data[victim.offset + 9 + 200] ^= 0x40
    bad = _write(tmp_path, bytes(data), "flipped.mcap")
    with pytest.raises(CorruptLogError, match="--recover"):
        replay(bad)
    summary = replay(bad, ReplayOptions(recover=True))
    rec = summary.recovered
    assert rec is not None and rec["bad_chunks"] == 1 and not rec["truncated"]
    lost = rec["lost"][0]
    assert lost["offset"] == victim.offset and lost["messages"] > 0
    assert lost["start_s"] is not None and lost["end_s"] >= lost["start_s"]


def test_nothing_replayed_is_an_error(tmp_path: Path) -> None:
    with pytest.raises((NoFramesError, UsageError)):
        replay(GOLDEN / "scenario2.mcap", ReplayOptions(start_s=100.0))


def test_metadata_found_without_its_index(tmp_path: Path) -> None:
    from mcap.writer import IndexType

    raw = read_raw(GOLDEN / "rolling.mcap")
    path = _write(tmp_path, write_raw(raw, index_types=IndexType.NONE))
    with LogReader(path) as log:
        assert log.info.cameras.by_robot().keys() == {"robot1", "robot2", "robot3"}


def test_recorder_log_without_a_camera_is_an_error(tmp_path: Path) -> None:
    raw = read_raw(GOLDEN / "rolling.mcap")
    raw.metadata = [(n, {k: v for k, v in d.items() if k != "robot2"})
                    if n == "dsp.cameras" else (n, d) for n, d in raw.metadata]
    with pytest.raises(DspError, match=r"dsp.cameras has no camera for robot2"):
        replay(_write(tmp_path, write_raw(raw)))


def test_not_mcap(tmp_path: Path) -> None:
    with pytest.raises(NotMcapError):
        replay(_write(tmp_path, b"PK\x03\x04" + bytes(100)))


def test_float64_redeclared_float32_is_refused(tmp_path: Path) -> None:
    raw = read_raw(GOLDEN / "scenario2.mcap")
    for sid, (name, enc, text) in raw.schemas.items():
        if name == "geometry_msgs/msg/PoseStamped":
            raw.schemas[sid] = (name, enc, text.replace(b"float64", b"float32"))
    with pytest.raises(SchemaError, match=r"float32 x.*ROS 2 definition"):
        replay(_write(tmp_path, write_raw(raw)))


def test_rosbag2_style_definitions_are_accepted() -> None:
    from replay.log.schemas import definition_mismatch

    text = ("# A Pose with reference coordinate frame and timestamp\nstd_msgs/Header header\n"
            "Pose pose\n" + "=" * 80 + "\nMSG: geometry_msgs/Pose\n# comment\n"
            "Point position\nQuaternion orientation\n" + "=" * 80 + "\nMSG: std_msgs/Header\n"
            "builtin_interfaces/Time stamp\nstring frame_id\n" + "=" * 80
            + "\nMSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\n"
            "float64 w 1\n")
    assert definition_mismatch("geometry_msgs/msg/PoseStamped", text) is None
    assert definition_mismatch("geometry_msgs/msg/PoseStamped",
                               text.replace("float64 w", "float32 w")) is not None


def test_damaged_images_print_nothing(capfd: pytest.CaptureFixture[str]) -> None:
    import cv2
    import numpy as np

    img = np.zeros((120, 120, 3), np.uint8)
    cv2.circle(img, (60, 60), 20, (0, 0, 255), -1)
    rng = random.Random(5)
    for ext, fmt in ((".jpg", "jpeg"), (".png", "png")):
        data = cv2.imencode(ext, img)[1].tobytes()
        for _ in range(20):
            buf = bytearray(data)
            buf[rng.randrange(30, len(buf))] ^= 1 << rng.randrange(8)
            decode_image(ImageMessage("robot1", 0, 0, fmt, bytes(buf)))
        assert decode_image(ImageMessage("robot1", 0, 0, fmt, data[: len(data) // 2])) is None
    captured = capfd.readouterr()
    assert captured.err == "" and captured.out == ""


def test_recover_reads_the_complete_messages_of_an_unchunked_tail(tmp_path: Path) -> None:
    raw = read_raw(GOLDEN / "rolling.mcap")
    path = _write(tmp_path, write_raw(raw, use_chunking=False), "unchunked.mcap")
    full = replay(path).frames
    data = path.read_bytes()
    cut = _write(tmp_path, data[: len(data) // 2], "cut.mcap")
    summary = replay(cut, ReplayOptions(recover=True))
    assert 0.35 * full <= summary.frames < full
    rec = summary.recovered
    assert rec is not None and rec["truncated"] and rec["bad_chunks"] == 0


def test_golden_rolling_log_cut_in_half_recovers(tmp_path: Path) -> None:
    data = (GOLDEN / "rolling.mcap").read_bytes()
    cut = _write(tmp_path, data[: len(data) // 2], "half.mcap")
    full = replay(GOLDEN / "rolling.mcap").frames
    assert replay(cut, ReplayOptions(recover=True)).frames >= 0.35 * full
