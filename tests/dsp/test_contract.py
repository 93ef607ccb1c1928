"""The log contract module: shared by recorder and replay, importable without pybullet."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer

from dsp import contract, metadata


def test_importing_the_contract_does_not_import_the_simulator() -> None:
    code = "import dsp.contract, sys; print('pybullet' in sys.modules, 'mcap' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


@pytest.mark.parametrize(
    ("topics", "expected"),
    [
        (["/robot1/pose", "/robot10/pose", "/robot2/pose", "/tf"], ["robot1", "robot2", "robot10"]),
        (["/ground_truth/robot1/pose"], []),
        (["/keeper/pose", "/striker/pose"], ["keeper", "striker"]),
    ],
)
def test_robot_names_are_found_in_natural_order(topics: list[str], expected: list[str]) -> None:
    assert contract.robot_names_in(topics, contract.POSE_TOPIC) == expected


def test_a_pattern_without_placeholder_is_refused() -> None:
    with pytest.raises(ValueError, match="no '\\{robot\\}' placeholder"):
        contract.robot_names_in(["/a"], "/robot1/pose")


@pytest.mark.parametrize("t_ns", [0, 1, 999_999_999, 1_000_000_000, 12_345_678_901])
def test_stamps_round_trip(t_ns: int) -> None:
    stamp = contract.stamp_from_ns(t_ns)
    assert 0 <= stamp["nanosec"] < 1_000_000_000

    class Stamp:
        sec = stamp["sec"]
        nanosec = stamp["nanosec"]

    assert contract.stamp_to_ns(Stamp()) == t_ns


_HEADER = {"stamp": {"sec": 3, "nanosec": 5}, "frame_id": contract.FIELD_FRAME}
_POSE = {"position": {"x": 1.5, "y": -2.0, "z": 0.0},
         "orientation": {"x": 0.0, "y": 0.0, "z": 0.6, "w": 0.8}}
_SAMPLES = {
    contract.COMPRESSED_IMAGE: {"header": _HEADER, "format": "png", "data": b"\x89PNG"},
    contract.IMAGE: {"header": _HEADER, "height": 1, "width": 2, "encoding": "bgr8",
                     "is_bigendian": 0, "step": 6, "data": bytes(6)},
    contract.POSE_STAMPED: {"header": _HEADER, "pose": _POSE},
    contract.POINT_STAMPED: {"header": _HEADER, "point": {"x": 1.0, "y": 2.0, "z": 0.11}},
    contract.POSE_WITH_COVARIANCE_STAMPED: {
        "header": _HEADER, "pose": {"pose": _POSE, "covariance": [float(i) for i in range(36)]}},
    contract.ODOMETRY: {
        "header": _HEADER, "child_frame_id": "ball",
        "pose": {"pose": {"position": {"x": 1.5, "y": -2.0, "z": 0.0},
                          "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
                 "covariance": [1.0, 2.0] + [0.0] * 4 + [3.0, 4.0] + [0.0] * 28},
        "twist": {"twist": {"linear": {"x": 4.0, "y": -1.0, "z": 0.0},
                            "angular": {"x": 0.0, "y": 0.0, "z": 0.0}},
                  "covariance": [0.5] + [0.0] * 6 + [0.25] + [0.0] * 28}},
    contract.TF_MESSAGE: {"transforms": [{
        "header": _HEADER, "child_frame_id": "robot1",
        "transform": {"translation": {"x": 1.0, "y": 2.0, "z": 0.0},
                      "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}]},
}


def test_every_message_definition_has_a_sample() -> None:
    assert set(_SAMPLES) == set(contract.MESSAGE_DEFINITIONS)


@pytest.mark.parametrize("schema_name", sorted(_SAMPLES))
def test_message_definitions_round_trip_through_cdr(schema_name: str) -> None:
    buf = io.BytesIO()
    writer = Writer(buf)
    schema = writer.register_msgdef(schema_name, contract.MESSAGE_DEFINITIONS[schema_name])
    writer.write_message("/t", schema, _SAMPLES[schema_name], log_time=7, publish_time=7)
    writer.finish()
    buf.seek(0)
    decoded = list(make_reader(buf, decoder_factories=[DecoderFactory()]).iter_decoded_messages())
    assert len(decoded) == 1
    got_schema, _, message, msg = decoded[0]
    assert got_schema.name == schema_name
    assert message.log_time == 7
    if schema_name == contract.TF_MESSAGE:
        assert msg.transforms[0].child_frame_id == "robot1"
        assert contract.stamp_to_ns(msg.transforms[0].header.stamp) == 3_000_000_005
    else:
        assert contract.stamp_to_ns(msg.header.stamp) == 3_000_000_005
    if schema_name == contract.POSE_WITH_COVARIANCE_STAMPED:
        assert list(msg.pose.covariance) == [float(i) for i in range(36)]
        assert msg.pose.pose.orientation.z == pytest.approx(0.6)
    if schema_name == contract.ODOMETRY:
        assert msg.child_frame_id == "ball"
        assert (msg.twist.twist.linear.x, msg.twist.twist.linear.y) == (4.0, -1.0)
        assert msg.twist.covariance[7] == 0.25 and msg.pose.covariance[6] == 3.0


# --- message builders ------------------------------------------------------------------------
_Q = (0.0, 0.0, 0.6, 0.8)
_T = 3_000_000_005


def test_builders_make_the_messages_the_definitions_describe() -> None:
    built = {
        contract.COMPRESSED_IMAGE: contract.compressed_image(_T, contract.FIELD_FRAME, "png",
                                                             b"\x89PNG"),
        contract.POSE_STAMPED: contract.pose_stamped(_T, 1.5, -2.0, 0.0, _Q),
        contract.POINT_STAMPED: contract.point_stamped(_T, 1.0, 2.0, 0.11),
        contract.TF_MESSAGE: contract.tf_message(
            [contract.transform_stamped(_T, "robot1", 1.0, 2.0, 0.0)]),
        contract.ODOMETRY: contract.odometry(
            _T, "ball", 1.5, -2.0, 4.0, -1.0, position_covariance=((1.0, 2.0), (3.0, 4.0)),
            velocity_covariance=((0.5, 0.0), (0.0, 0.25))),
    }
    for name, msg in built.items():
        assert msg == _SAMPLES[name], name


def test_the_fused_covariance_fills_the_xy_block() -> None:
    msg = contract.pose_with_covariance_stamped(_T, 1.5, -2.0, ((1.0, 2.0), (3.0, 4.0)), q=_Q)
    assert msg["header"] == _HEADER and msg["pose"]["pose"] == _POSE
    cov = msg["pose"]["covariance"]
    assert len(cov) == 36 and (cov[0], cov[1], cov[6], cov[7]) == (1.0, 2.0, 3.0, 4.0)
    assert sum(cov) == 10.0


# --- metadata records ------------------------------------------------------------------------
GOLDEN = Path(__file__).resolve().parents[2] / "logs" / "golden"
_RECORDS = {
    contract.SCENARIO_METADATA: metadata.ScenarioMetadata,
    contract.CAMERAS_METADATA: metadata.CamerasMetadata,
    contract.RECORDER_METADATA: metadata.RecorderMetadata,
}


@pytest.mark.parametrize("log", ["scenario4.mcap", "rolling.mcap"])
def test_golden_metadata_round_trips_exactly(log: str) -> None:
    with (GOLDEN / log).open("rb") as f:
        records = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    assert set(records) == set(_RECORDS)
    for name, cls in _RECORDS.items():
        typed = cls.from_metadata(records[name])  # type: ignore[attr-defined]
        assert typed.to_metadata() == records[name], name
    scenario = metadata.ScenarioMetadata.from_metadata(records[contract.SCENARIO_METADATA])
    assert scenario.field.name == "18x12" and scenario.recording is not None
    assert scenario.pose_rate_hz == 2 * scenario.recording.rate_hz


def test_a_scenario_without_field_or_recording_is_read() -> None:
    """Logs written by other tools may carry only the name, seed and their own params."""
    s = metadata.ScenarioMetadata.from_metadata(
        {"name": "synthetic", "seed": "0", "params": '{"field_length_m":18.0}'})
    assert (s.field_name, s.recording, s.pose_rate_hz) == (None, None, None)
    assert s.field.name == "18x12"
    assert s.scene == {"field_length_m": 18.0}


_GOOD_SCENARIO = {"name": "x", "seed": "0", "params": "{}"}


@pytest.mark.parametrize(("cls", "data", "match"), [
    (metadata.ScenarioMetadata, {"name": "x", "seed": "0"}, "no 'params'"),
    (metadata.ScenarioMetadata, {**_GOOD_SCENARIO, "params": "{oops"}, "params is not JSON"),
    (metadata.ScenarioMetadata, {**_GOOD_SCENARIO, "params": "[1]"}, "not a JSON object"),
    (metadata.ScenarioMetadata, {**_GOOD_SCENARIO, "seed": "zero"}, "seed = 'zero'"),
    (metadata.ScenarioMetadata, {**_GOOD_SCENARIO, "params": '{"field":"30x20"}'},
     "unknown field '30x20'"),
    (metadata.ScenarioMetadata, {**_GOOD_SCENARIO, "params": '{"recording":{"rate_hz":5}}'},
     "no 'pose_rate_hz'"),
    (metadata.CamerasMetadata, {"robot1": "not json"}, "robot1 is not JSON"),
    (metadata.CamerasMetadata, {"robot1": '{"cu_px": 1}'}, "robot1.model"),
    (metadata.RecorderMetadata, {"renderer": "egl", "physics_hz": "fast", "face_px": "256"},
     "physics_hz = 'fast'"),
])
def test_unreadable_metadata_is_an_error(cls: Any, data: dict[str, str], match: str) -> None:
    with pytest.raises(metadata.MetadataError, match=match):
        cls.from_metadata(data)
    assert issubclass(metadata.MetadataError, ValueError)


def test_the_reader_names_the_log_with_unreadable_metadata(tmp_path: Path) -> None:
    from replay.log import LogReader

    path = tmp_path / "bad.mcap"
    with path.open("wb") as f:
        writer = Writer(f)
        schemas = {name: writer.register_msgdef(name, contract.MESSAGE_DEFINITIONS[name])
                   for name in (contract.COMPRESSED_IMAGE, contract.POSE_STAMPED)}
        writer.write_message("/robot1/pose", schemas[contract.POSE_STAMPED],
                             contract.pose_stamped(0, 0.0, 0.0, 0.0), log_time=0, publish_time=0)
        writer.write_message("/robot1/omni/image/compressed", schemas[contract.COMPRESSED_IMAGE],
                             contract.compressed_image(0, "robot1/omni", "png", b""),
                             log_time=0, publish_time=0)
        writer.add_metadata(contract.SCENARIO_METADATA, {"name": "x", "seed": "0",
                                                         "params": "{not json"})
        writer.finish()
    with pytest.raises(metadata.MetadataError, match=r"bad\.mcap: metadata dsp\.scenario"):
        with LogReader(path):
            pass
