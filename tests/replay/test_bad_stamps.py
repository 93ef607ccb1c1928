"""A stamp far off costs its own message only: an image stamped far in the future is a bad
message (skipped, counted, warned about), one stamped ahead but within the bound waits without
holding the others back, and poses stamped in reverse keep the poses the images need."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import pytest
from fuzzing import read_raw, write_raw
from synthetic import write_log

from estimator.constants import NS_PER_S as NS
from replay.cli import main
from replay.log import ImageMessage, PoseMessage
from replay.options import ReplayOptions
from replay.runner import replay
from replay.sync import DelayLine, History


def _restamp(data: bytes, stamp_ns: int) -> bytes:
    """A CDR message (std_msgs/Header first) with its header stamp replaced."""
    return data[:4] + struct.pack("<iI", stamp_ns // NS, stamp_ns % NS) + data[12:]


def _stamp(data: bytes) -> int:
    sec, nsec = struct.unpack_from("<iI", data, 4)
    return int(sec) * NS + int(nsec)


@pytest.fixture(scope="module")
def twenty(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 20-step log: three robots, images at 10 Hz for 1.95 s."""
    path = tmp_path_factory.mktemp("stamps") / "twenty.mcap"
    write_log(path, duration_s=1.95, image_hz=10.0, with_cameras=True)
    return path


def _shift_one(src: Path, dst: Path, topic_end: str, by_ns: int, which: int = 7) -> Path:
    raw = read_raw(src)
    topics = {cid: c[0] for cid, c in raw.channels.items()}
    hits = [i for i, m in enumerate(raw.messages)
            if topics[m[0]].endswith(topic_end) and not topics[m[0]].startswith("/ground")]
    cid, seq, log_time, publish, data = raw.messages[hits[which]]
    raw.messages[hits[which]] = (cid, seq, log_time, publish,
                                 _restamp(data, _stamp(data) + by_ns))
    dst.write_bytes(write_raw(raw))
    return dst


def _fused(path: Path, fusion: str = "mean") -> int:
    summary = replay(path, ReplayOptions(fusion=fusion, progress=False))
    return summary.fused_steps


def test_one_image_far_in_the_future_is_a_bad_message(
        twenty: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The issue's case: one image stamped a million seconds ahead gave 1 step and 0 fused;
    now it is skipped and counted, and the 20 steps fuse as in the intact log."""
    intact = _fused(twenty)
    assert intact == 20
    for which in (0, 7, 59):  # the first image of the log, one in the middle, the last
        bad = _shift_one(twenty, tmp_path / f"future{which}.mcap", "/compressed", 10**6 * NS,
                         which)
        out = tmp_path / "r.json"
        assert main([str(bad), "--fusion", "mean", "--out", str(out), "--force",
                     "--no-progress"]) == 0
        err = capsys.readouterr().err
        assert (f"warning: {bad}: skipped 1 bad message(s): bad image: stamp over 600 s away "
                "from the rest of the log 1") in err
        results = json.loads(out.read_text())
        assert len(results["frames"]) == 59
        assert results["summary"]["fused_steps"] >= 19
    assert _fused(bad, "track") >= _fused(twenty, "track") - 1


def test_an_image_ahead_within_the_bound_costs_its_own_frame(twenty: Path,
                                                              tmp_path: Path) -> None:
    """300 s ahead is not absurd: the image waits in the delay line without holding back
    the images behind it, and ends as one frame without a pose."""
    bad = _shift_one(twenty, tmp_path / "ahead.mcap", "/compressed", 300 * NS)
    summary = replay(bad, ReplayOptions(fusion="mean", progress=False))
    assert summary.frames == 60 and summary.skipped == {"no_pose": 1}
    assert summary.fused_steps >= 19


def test_a_pose_ahead_does_not_push_out_the_poses_images_need(twenty: Path,
                                                               tmp_path: Path) -> None:
    bad = _shift_one(twenty, tmp_path / "pose.mcap", "/pose", 300 * NS, which=20)
    summary = replay(bad, ReplayOptions(fusion="mean", progress=False))
    assert summary.skipped == {} and summary.fused_steps == 20


def test_poses_in_reverse_order_fuse_the_frames_they_can(tmp_path: Path) -> None:
    """20,001 poses whose stamps run backwards (each pose right for its stamp, written in
    reverse): a frame can be paired when its pose arrives within the look-ahead, i.e. from
    the middle of the log on. Those frames are fused (this used to fuse 0 steps: the first
    pose, stamped at the end, pushed every later one out of the history)."""
    src = tmp_path / "forward.mcap"
    write_log(src, duration_s=133.4, image_hz=1.0, pose_hz=50.0, with_cameras=True)
    raw = read_raw(src)
    topics = {cid: c[0] for cid, c in raw.channels.items()}
    poses = 0
    for cid, topic in topics.items():
        if not topic.endswith("/pose") or topic.startswith("/ground"):
            continue
        idx = [i for i, m in enumerate(raw.messages) if m[0] == cid]
        datas = [raw.messages[i][4] for i in idx][::-1]
        for i, data in zip(idx, datas, strict=True):
            c, s, log_time, publish, _ = raw.messages[i]
            raw.messages[i] = (c, s, log_time, publish, data)
        poses += len(idx)
    assert poses >= 20_000
    path = tmp_path / "reversed.mcap"
    path.write_bytes(write_raw(raw))
    options = ReplayOptions(fusion="mean", progress=False)
    t = options.timing()
    # the frames whose pose arrives (log time) by the time the look-ahead releases them
    arrival = {}
    for cid, _seq, log_time, _pub, data in raw.messages:
        if topics[cid].endswith("/pose") and not topics[cid].startswith("/ground"):
            arrival[(topics[cid], _stamp(data))] = log_time
    usable_steps = 0
    images = sorted({_stamp(m[4]) for m in raw.messages if topics[m[0]].endswith("compressed")})
    for stamp in images:
        usable_steps += all(arrival.get((f"/{r}/pose", stamp), 1 << 62) <= stamp + t.lookahead_ns
                            for r in ("robot1", "robot2", "robot3"))
    summary = replay(path, options)
    assert usable_steps >= 0.4 * len(images)
    assert summary.fused_steps >= usable_steps - 2
    assert summary.fused_steps < len(images)  # the first half cannot be paired


def _image(robot: str, stamp_ns: int) -> ImageMessage:
    return ImageMessage(robot, stamp_ns, stamp_ns, "png", b"x")


def test_the_delay_line_hands_images_on_in_stamp_order() -> None:
    line = DelayLine(lookahead_ns=10)
    for robot, stamp in (("a", 5), ("b", 1000), ("c", 3), ("d", 5), ("e", 7)):
        line.push(_image(robot, stamp))
    assert line.clock_ns == 3
    assert [i.robot for i in line.ready(20)] == ["c", "a", "d", "e"]  # not held back by "b"
    assert line.clock_ns == 1000 and [i.robot for i in line.drain()] == ["b"]
    assert line.clock_ns == 1000 and len(line) == 0


def test_a_history_prunes_behind_the_images_still_to_come() -> None:
    """Guards the history's horizon: a sample stamped far ahead prunes nothing an image
    still waiting (clock_ns) may need; without a clock, the newest sample sets it."""
    history: History[PoseMessage] = History(horizon_ns=100)
    for t in range(0, 1000, 10):
        history.add(PoseMessage("r", t, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0), clock_ns=950)
    history.add(PoseMessage("r", 10**9, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0), clock_ns=990)
    before, after = history.neighbours(955)
    assert before is not None and after is not None
    assert (before.stamp_ns, after.stamp_ns) == (950, 960)
    alone: History[PoseMessage] = History(horizon_ns=100)
    for t in (0, 500, 10**9):
        alone.add(PoseMessage("r", t, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    assert len(alone) == 2  # 500, kept as the one at or before the limit, and 10**9
