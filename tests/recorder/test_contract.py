"""The log contract module: shared by recorder and replay, importable without pybullet."""

from __future__ import annotations

import io
import subprocess
import sys

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer

from recorder import contract


def test_importing_the_contract_does_not_import_the_simulator() -> None:
    code = "import recorder.contract, sys; print('pybullet' in sys.modules, 'mcap' in sys.modules)"
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
