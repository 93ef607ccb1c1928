"""The ROS 2 message definitions the logs carry are ROS 2's own: every schema in
dsp.contract, in the golden logs and in an estimates MCAP parses, type by type and field by
field, to what rosbags' ROS 2 type store holds (rosbags ships the definitions of the ROS 2
distributions), with every dependency present."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader

from dsp import contract
from replay.options import ReplayOptions
from replay.runner import replay

typesys = pytest.importorskip("rosbags.typesys")
STORE = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
GOLDEN = Path(__file__).resolve().parents[2] / "logs" / "golden"


def _closure(name: str) -> set[str]:
    """``name`` and every message type its fields use, as rosbags knows them."""
    seen: set[str] = set()
    todo = [name]
    while todo:
        typename = todo.pop()
        if typename in seen:
            continue
        seen.add(typename)
        for _field, (kind, detail) in STORE.fielddefs[typename][1]:
            inner = detail[0] if kind.name in ("ARRAY", "SEQUENCE") else (kind, detail)
            if inner[0].name == "NAME":
                todo.append(inner[1])
    return seen


def assert_is_ros2(name: str, text: str) -> None:
    parsed = typesys.get_types_from_msg(text, name)
    assert set(parsed) == _closure(name), f"{name}: dependencies differ"
    for typename, definition in parsed.items():
        assert definition == STORE.fielddefs[typename], f"{name}: {typename} differs"


@pytest.mark.parametrize("name", sorted(contract.MESSAGE_DEFINITIONS))
def test_each_contract_definition_is_the_ros2_one(name: str) -> None:
    assert_is_ros2(name, contract.MESSAGE_DEFINITIONS[name])


def test_odometry_is_among_them() -> None:
    assert contract.ODOMETRY == "nav_msgs/msg/Odometry"
    assert "geometry_msgs/msg/TwistWithCovariance" in _closure(contract.ODOMETRY)
    assert_is_ros2(contract.ODOMETRY, contract.MESSAGE_DEFINITIONS[contract.ODOMETRY])


def test_a_wrong_definition_is_caught() -> None:
    text = contract.MESSAGE_DEFINITIONS[contract.POSE_STAMPED].replace("float64 z\n",
                                                                       "float32 z\n", 1)
    with pytest.raises(AssertionError, match="geometry_msgs/msg/Point differs"):
        assert_is_ros2(contract.POSE_STAMPED, text)


def _schemas(path: Path) -> dict[str, tuple[str, str]]:
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return {s.name: (s.encoding, s.data.decode()) for s in summary.schemas.values()}


@pytest.mark.parametrize("log", sorted(p.name for p in GOLDEN.glob("*.mcap")))
def test_the_golden_logs_schemas_are_the_ros2_definitions(log: str) -> None:
    schemas = _schemas(GOLDEN / log)
    assert contract.COMPRESSED_IMAGE in schemas and contract.POSE_STAMPED in schemas
    for name, (encoding, text) in schemas.items():
        assert encoding == "ros2msg"
        assert text == contract.MESSAGE_DEFINITIONS[name]  # the bytes the contract writes
        assert_is_ros2(name, text)


def test_an_estimates_logs_schemas_are_the_ros2_definitions(tmp_path: Path) -> None:
    out = tmp_path / "estimates.mcap"
    replay(GOLDEN / "rolling.mcap", ReplayOptions(out_mcap=out, progress=False))
    schemas = _schemas(out)
    assert schemas
    for name, (encoding, text) in schemas.items():
        assert encoding == "ros2msg"
        assert_is_ros2(name, text)
