"""The log reader: log-time order with file order on ties, raw images, bad files, --recover."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap_ros2.writer import Writer
from synthetic import write_log

from dsp import contract
from replay.errors import (
    MAX_LISTED_TOPICS,
    InputNotFoundError,
    NoImageTopicsError,
    NoPoseTopicError,
    NotMcapError,
    TruncatedLogError,
)
from replay.log import ImageMessage, LogReader, PoseMessage, decode_image


def _write_ties(path: Path) -> list[tuple[str, int, float]]:
    """Messages on several topics with equal log times, across several small chunks."""
    expected = []
    with path.open("wb") as f:
        w = Writer(f, chunk_size=200)
        pose_s = w.register_msgdef(contract.POSE_STAMPED,
                                   contract.MESSAGE_DEFINITIONS[contract.POSE_STAMPED])
        img_s = w.register_msgdef(contract.COMPRESSED_IMAGE,
                                  contract.MESSAGE_DEFINITIONS[contract.COMPRESSED_IMAGE])
        k = 0
        for t in (0, 0, 0, 5, 5, 10, 10, 10):
            for robot in ("robot2", "robot1"):
                k += 1
                msg = {"header": {"stamp": contract.stamp_from_ns(t), "frame_id": "field"},
                       "pose": {"position": {"x": float(k), "y": 0.0, "z": 0.0},
                                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
                w.write_message(f"/{robot}/pose", pose_s, msg, log_time=t, publish_time=t)
                expected.append(("pose", t, float(k)))
            img = {"header": {"stamp": contract.stamp_from_ns(t), "frame_id": "robot1/omni"},
                   "format": "png", "data": bytes([k])}
            w.write_message("/robot1/omni/image/compressed", img_s, img, log_time=t,
                            publish_time=t)
            expected.append(("image", t, float(k)))
        w.finish()
    return expected


@pytest.mark.parametrize("recover", [False, True])
def test_equal_stamps_keep_file_order(tmp_path: Path, recover: bool) -> None:
    path = tmp_path / "ties.mcap"
    expected = _write_ties(path)
    got = []
    with LogReader(path, recover=recover) as log:
        assert log.info.robots == ("robot1",)
        for m in log.messages():
            if isinstance(m, PoseMessage):
                got.append(("pose", m.stamp_ns, m.x_m))
            elif isinstance(m, ImageMessage):
                got.append(("image", m.stamp_ns, float(m.data[0])))
    # robot2's poses are not read (robot2 has no images); the rest keeps file order
    wanted = [e for e in expected if not (e[0] == "pose" and int(e[2]) % 2 == 1)]
    assert got == wanted


@pytest.mark.parametrize("encoding", ["bgr8", "rgb8", "mono8", "png", "jpeg"])
def test_image_encodings_decode(tmp_path: Path, encoding: str) -> None:
    path = tmp_path / f"{encoding}.mcap"
    write_log(path, duration_s=0.1, image_encoding=encoding, robots={"robot1": (0, 0, 0)})
    topic = contract.IMAGE_TOPIC if encoding in ("png", "jpeg") else "/{robot}/omni/image"
    with LogReader(path, image_topic=topic) as log:
        images = [m for m in log.messages() if isinstance(m, ImageMessage)]
    assert len(images) == 2
    img = decode_image(images[0])
    assert img is not None and img.shape == (1080, 1080, 3)
    if encoding != "mono8":
        assert np.abs(img[0, 0].astype(int) - (30, 90, 20)).max() <= 4  # BGR order kept


def test_bad_files(tmp_path: Path) -> None:
    with pytest.raises(InputNotFoundError, match=r"missing\.mcap: no such file"):
        LogReader(tmp_path / "missing.mcap").__enter__()
    with pytest.raises(InputNotFoundError, match="is a folder, not a log"):
        LogReader(tmp_path).__enter__()
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"hello, not an mcap at all")
    with pytest.raises(NotMcapError, match=r"junk\.mcap: not an MCAP"):
        LogReader(junk).__enter__()
    log = tmp_path / "log.mcap"
    write_log(log, duration_s=0.2)
    with pytest.raises(NoImageTopicsError, match="no image topics"):
        LogReader(log, image_topic="/{robot}/camera").__enter__()
    cut = tmp_path / "cut.mcap"
    data = log.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(TruncatedLogError, match=r"cut\.mcap: the log is truncated"):
        LogReader(cut).__enter__()



@pytest.fixture(scope="module")
def many_topics(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Six robots (13 topics), one named with a terminal escape sequence."""
    path = tmp_path_factory.mktemp("topics") / "many.mcap"
    names = ["robot\x1b]0;owned\x07", *(f"robot{i}" for i in range(1, 6))]
    write_log(path, duration_s=0.1, robots={n: (float(i), 0.0, 0.0) for i, n in enumerate(names)})
    return path


def _listed(message: str, path: Path) -> None:
    """The log's topics, terminal-safe and bounded, and the command that lists them all."""
    assert "\x1b" not in message and "\x07" not in message
    assert "the log's topics: /ground_truth/ball, /robot\\x1b]0;owned\\x07/omni/" in message
    assert f"and {13 - MAX_LISTED_TOPICS} more (dsp-info {path} lists them" in message


def test_a_missing_image_topic_lists_the_log_s_topics(many_topics: Path) -> None:
    with pytest.raises(NoImageTopicsError, match=r"'/\{robot\}/camera' \(the --image-topic "
                       r"given\); the log's topics: ") as given:
        LogReader(many_topics, image_topic="/{robot}/camera").__enter__()
    _listed(str(given.value), many_topics)
    assert "set --image-topic" not in str(given.value)
    with pytest.raises(NoImageTopicsError, match=r"for robots robot9 \(its robots are "
                       r"robot1, .*, robot\\x1b]0;owned\\x07: check --robots\)"):
        LogReader(many_topics, robots=["robot9"]).__enter__()


def test_a_missing_pose_topic_suggests_the_pose_topic_not_the_tolerance(
        many_topics: Path) -> None:
    with pytest.raises(NoPoseTopicError, match=r"missing poses: no pose topic '/\{robot\}/odom' "
                       r"for robot1, .*, robot\\x1b]0;owned\\x07 \(the --pose-topic given\); "
                       ) as given:
        LogReader(many_topics, pose_topic="/{robot}/odom").__enter__()
    _listed(str(given.value), many_topics)
    assert "--pose-tolerance" not in str(given.value)


def test_recover_reads_complete_chunks(tmp_path: Path) -> None:
    log = tmp_path / "log.mcap"
    write_log(log, duration_s=1.0, chunk_size=20_000)
    with LogReader(log) as full:
        n_full = sum(1 for _ in full.messages())
    data = log.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.6)])
    with LogReader(cut, recover=True) as part:
        msgs = list(part.messages())
        assert part.loss.truncated
        assert 0 < part.loss.lost_bytes < len(data)
    assert 0 < len(msgs) < n_full
    stamps = [m.stamp_ns for m in msgs]
    assert stamps == sorted(stamps)
