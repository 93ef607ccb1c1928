"""dsp-info names a foreign log's robots from its topics, prints each camera's description,
and writes a starting camera file (--cameras-template): from the metadata when the log has
some, else from its images' size, with the calibration left to fill in."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fuzzing import GOLDEN
from synthetic import B_M, K_M_PER_PX, write_log

from dsp import contract
from dsp.camera_file import read_camera_file
from dsp.topics import infer_patterns
from replay import ReplayOptions, replay
from replay.info.cli import main

TEAM = {"image_topic": "/{robot}/camera/image_raw", "pose_topic": "/{robot}/amcl_pose"}


@pytest.fixture(scope="module")
def team_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A team's own layout: raw bgr8 images on /{robot}/camera/image_raw, AMCL poses."""
    team = tmp_path_factory.mktemp("team") / "team.mcap"
    write_log(team, duration_s=0.3, cameras=None, image_encoding="bgr8",
              image_size_px=(1280, 1024), centre_px=(640.0, 512.0),
              pose_schema=contract.POSE_WITH_COVARIANCE_STAMPED, **TEAM)
    return team


def test_patterns_are_found_from_the_topics() -> None:
    types = {"/robot1/camera/image_raw": "sensor_msgs/msg/Image",
             "/robot2/camera/image_raw": "sensor_msgs/msg/Image",
             "/robot1/amcl_pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
             "/robot2/amcl_pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
             "/robot1/odom": "nav_msgs/msg/Odometry",
             "/ground_truth/robot1/pose": "geometry_msgs/msg/PoseStamped",
             "/tf": "tf2_msgs/msg/TFMessage"}
    found = infer_patterns(types)
    assert found is not None and found.robots == ("robot1", "robot2")
    assert found.image_topic == "/{robot}/camera/image_raw"
    assert found.pose_topic == "/{robot}/amcl_pose"  # robot2 has no /odom
    lone = infer_patterns({"/keeper/cam/image": "sensor_msgs/msg/CompressedImage"})
    assert lone is not None and lone.robots == ("keeper",) and lone.pose_topic is None
    assert infer_patterns({"/tf": "tf2_msgs/msg/TFMessage"}) is None


def test_the_pose_pattern_of_a_log_with_thousands_of_robots() -> None:
    """Every robot has /{robot}/pose and /{robot}/nav/pose but one lacks /{robot}/p: the
    shortest complete pattern wins (the search checks each pattern once, against a set)."""
    n = 3000
    types = {f"/r{i}/omni/image": "sensor_msgs/msg/Image" for i in range(n)}
    for i in range(n):
        types[f"/r{i}/nav/pose"] = "geometry_msgs/msg/PoseStamped"
        types[f"/r{i}/pose"] = "geometry_msgs/msg/PoseStamped"
        if i != 1234:
            types[f"/r{i}/p"] = "geometry_msgs/msg/PoseStamped"
    found = infer_patterns(types)
    assert found is not None and len(found.robots) == n and found.robots[10] == "r10"
    assert found.pose_topic == "/{robot}/pose"
    del types["/r7/pose"]
    found = infer_patterns(types)
    assert found is not None and found.pose_topic == "/{robot}/nav/pose"


def test_a_foreign_logs_robots_and_the_flags_that_replay_it(
        team_log: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(team_log)]) == 0
    out = capsys.readouterr().out
    assert "robots:      robot1, robot2, robot3" in out
    assert ("replay with --image-topic '/{robot}/camera/image_raw' --pose-topic "
            "'/{robot}/amcl_pose'") in out
    assert "cameras:     - (no camera description: dsp-replay needs --cameras" in out
    assert main([str(team_log), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["image_topic"] == TEAM["image_topic"] and doc["pose_topic"] == TEAM["pose_topic"]


def test_each_camera_of_a_recorded_log_is_described(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(GOLDEN / "scenario1.mcap")]) == 0
    out = capsys.readouterr().out
    assert "  robot1  ideal 1080x1080, centre (539, 539), calibration from the model" in out


def test_a_template_from_the_metadata_is_its_entries(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cams.json"
    assert main([str(GOLDEN / "rolling.mcap"), "--cameras-template", "-o", str(out)]) == 0
    assert capsys.readouterr().out == f"wrote {out}\n"
    doc = json.loads(out.read_text())
    from replay.log import LogReader

    with LogReader(GOLDEN / "rolling.mcap") as r:
        assert r.info.scenario is not None
        assert doc.pop("field") == r.info.scenario.field.name  # what the replay fits lines on
        assert doc == {k: dict(v) for k, v in r.info.cameras.by_robot().items()}
    cams = read_camera_file(out)
    assert cams.field is not None and cams.field == r.info.scenario.field
    a = replay(GOLDEN / "rolling.mcap", ReplayOptions(progress=False))
    b = replay(GOLDEN / "rolling.mcap", ReplayOptions(cameras=out, progress=False))
    assert a.fused == b.fused
    assert main([str(GOLDEN / "rolling.mcap"), "--cameras-template", "-o", str(out)]) == 3


def test_a_template_from_the_images_asks_for_the_calibration(
        team_log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cameras.yaml"
    assert main([str(team_log), "--cameras-template", "-o", str(out)]) == 0
    text = out.read_text()
    assert "its images are 1280 x 1024 px" in text and "calibration: null  # REQUIRED" in text
    assert "--image-topic '/{robot}/camera/image_raw' --pose-topic '/{robot}/amcl_pose'" in text
    from dsp.cameras import CameraDescriptionError

    with pytest.raises(CameraDescriptionError, match=r"default\.calibration is empty: fill it "
                       r"in \(dsp-calibrate --from-measurements or --from-log"):
        read_camera_file(out)
    line = f"{{model: linear, a_m_per_px: {K_M_PER_PX}, b_m: {B_M}}}"
    out.write_text(text.replace("calibration: null", f"calibration: {line}"))
    spec = read_camera_file(out).default
    assert spec is not None and spec.centre_px == (639.5, 511.5)
    s = replay(team_log, ReplayOptions(cameras=out, **TEAM, progress=False))
    assert s.fused.rmse_m is not None and s.fused.rmse_m < 0.02  # half a pixel off-centre


def test_template_options_are_checked(team_log: Path, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(team_log), "-o", str(tmp_path / "c.yaml")]) == 2
    assert "-o/--out only go with --cameras-template" in capsys.readouterr().err
    assert main([str(team_log), "--cameras-template", "-o", str(tmp_path / "c.txt")]) == 2
    assert main([str(team_log), "--cameras-template", "--image-topic", "/x"]) == 2
    assert main([str(team_log), "--cameras-template", "-o", str(team_log)]) == 2


def test_a_template_names_the_field_or_says_where_to(tmp_path: Path) -> None:
    named = tmp_path / "named.yaml"
    assert main([str(GOLDEN / "rolling.mcap"), "--cameras-template", "-o", str(named)]) == 0
    assert "\nfield: 18x12  # the field the log's dsp.scenario names" in named.read_text()
    cams = read_camera_file(named)
    assert cams.field is not None and cams.field.name == "18x12" and "field" not in cams.robots
    bag = tmp_path / "bag.mcap"  # a team's bag: no dsp metadata at all
    write_log(bag, duration_s=0.2, cameras=None, metadata=False, image_size_px=(1280, 1024),
              centre_px=(640.0, 512.0), **TEAM)
    out = tmp_path / "cameras.yaml"
    assert main([str(bag), "--cameras-template", "-o", str(out)]) == 0
    text = out.read_text()
    hint = ("# field: 18x12   # name your field to let the default correct poses from the "
            "field lines\n")
    assert hint in text
    line = f"{{model: linear, a_m_per_px: {K_M_PER_PX}, b_m: {B_M}}}"
    text = text.replace("calibration: null", f"calibration: {line}")
    out.write_text(text)
    assert read_camera_file(out).field is None  # a comment
    out.write_text(text.replace("# field: 18x12", "field: 18x12"))
    cams = read_camera_file(out)
    assert cams.field is not None and cams.field.name == "18x12"
    assert cams.default is not None and cams.default.centre_px == (639.5, 511.5)


def test_dsp_info_says_what_a_bag_lacks_for_the_default_pipeline(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / "bag.mcap"  # a team's bag: no dsp metadata, one robot, AMCL poses
    write_log(bag, robots={"keeper": (-8.0, 0.0, 0.0)}, duration_s=0.2, cameras=None,
              metadata=False, pose_schema=contract.POSE_WITH_COVARIANCE_STAMPED, **TEAM)
    assert main([str(bag)]) == 0
    out = capsys.readouterr().out
    block = out.split("default pipeline:\n", 1)[1].splitlines()[:4]
    assert block == [
        "  line fit: no: the log names no field (dsp.scenario metadata); name it in the "
        "camera file: field: 18x12 and no robot's camera model is known (a camera file's "
        "mirror, fisheye or ideal entry, or a lookup entry with height_m: --cameras FILE)",
        "  3-D track: no: one robot, no rays to cross",
        "  poses: the believed ones (one robot: no other ball to compare with)",
        "  pose covariance: in the pose messages (PoseWithCovarianceStamped; all zero means "
        "unknown: learnt from the log then)"]
    assert main([str(bag), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [line.split(":")[0] for line in doc["default_pipeline"]] == [
        "line fit", "3-D track", "poses", "pose covariance", "balls in the air"]
    assert doc["default_pipeline"][-1].startswith(
        "balls in the air: placed by the blob's width for keeper (no camera model)")
    pair = tmp_path / "pair.mcap"  # two robots: each one's bias from how their balls differ
    write_log(pair, robots={"keeper": (-8.0, 0.0, 0.0), "back": (-4.0, 1.0, 0.0)},
              duration_s=0.2, cameras=None, metadata=False, **TEAM)
    assert main([str(pair)]) == 0
    assert ("  poses: each robot's bias corrected from the ball (how it disagrees with the "
            "other robots')") in capsys.readouterr().out.splitlines()
