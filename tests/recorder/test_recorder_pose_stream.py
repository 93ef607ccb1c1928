"""The believed poses as recorded: yaw noise in the unit the option names (degrees), and the
pose rate the metadata states is the rate the poses are written at."""

from __future__ import annotations

import itertools
import json
import math
from typing import Any

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from recorder.record import RecordOptions, record

YAW_NOISE_DEG = 3.0
RATE_HZ = 4.0  # camera frames; poses at twice that
FRAMES = 3
ROBOTS = ("robot1", "robot2", "robot3")


Messages = dict[str, list[tuple[int, Any]]]
"""topic -> [(log_time_ns, decoded message)]"""
Metadata = dict[str, dict[str, str]]


def _yaw(q: Any) -> float:
    return 2.0 * math.atan2(q.z, q.w)


@pytest.fixture(scope="module")
def pose_log(tmp_path_factory: pytest.TempPathFactory) -> tuple[Messages, Metadata]:
    """topic -> [(log_time_ns, decoded message)] and metadata name -> record, of a tiny
    scenario1 recording with yaw noise only."""
    path = tmp_path_factory.mktemp("poses") / "scenario1.mcap"
    record(path, RecordOptions(frames=FRAMES, rate_hz=RATE_HZ, yaw_noise_deg=YAW_NOISE_DEG,
                               face_px=256))
    topics: Messages = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            topics.setdefault(channel.topic, []).append((message.log_time, decoded))
        f.seek(0)
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    return topics, meta


def test_yaw_noise_is_in_degrees(pose_log: tuple[Messages, Metadata]) -> None:
    topics, _ = pose_log
    errors_deg = []
    for robot in ROBOTS:
        believed = topics[f"/{robot}/pose"]
        truth = topics[f"/ground_truth/{robot}/pose"]
        assert [t for t, _ in believed] == [t for t, _ in truth]
        for (_, b), (_, g) in zip(believed, truth, strict=True):
            assert (b.pose.position.x, b.pose.position.y) == (g.pose.position.x,
                                                              g.pose.position.y)
            d = _yaw(b.pose.orientation) - _yaw(g.pose.orientation)
            errors_deg.append(math.degrees(math.atan2(math.sin(d), math.cos(d))))
    assert len(errors_deg) == 2 * FRAMES * len(ROBOTS)
    rms = math.sqrt(sum(e * e for e in errors_deg) / len(errors_deg))
    # 18 samples of N(0, 3 deg): an RMS between 1.5 and 6 deg, none beyond 5 sigma
    assert 0.5 * YAW_NOISE_DEG < rms < 2.0 * YAW_NOISE_DEG, errors_deg
    assert max(abs(e) for e in errors_deg) < 5 * YAW_NOISE_DEG, errors_deg


def test_metadata_rates_are_the_written_rates(pose_log: tuple[Messages, Metadata]) -> None:
    topics, meta = pose_log
    recording = json.loads(meta["dsp.scenario"]["params"])["recording"]
    assert recording["rate_hz"] == RATE_HZ
    assert recording["yaw_noise_deg"] == YAW_NOISE_DEG
    for robot in ROBOTS:
        for topic, key, n in ((f"/{robot}/pose", "pose_rate_hz", 2 * FRAMES),
                              (f"/ground_truth/{robot}/pose", "pose_rate_hz", 2 * FRAMES),
                              (f"/{robot}/omni/image/compressed", "rate_hz", FRAMES)):
            stamps = [t for t, _ in topics[topic]]
            assert len(stamps) == n, topic
            periods = {b - a for a, b in itertools.pairwise(stamps)}
            assert len(periods) == 1, topic
            assert recording[key] == pytest.approx(1e9 / periods.pop(), rel=1e-9), topic
