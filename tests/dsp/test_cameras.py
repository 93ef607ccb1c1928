"""The camera description: one schema for dsp.cameras metadata and camera files, parsed once
into frozen records, every bad field one line naming the source and the field."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import pytest

from dsp import contract, metadata
from dsp.camera_file import MAX_CAMERA_FILE_BYTES, camera_file_text, read_camera_file
from dsp.cameras import (
    PAPER_CAMERA,
    CameraDescriptionError,
    FieldTransform,
    camera_set_from_json,
    camera_spec_from_json,
)
from estimator.calibration import CameraCalibration, LinearCalibration, MirrorCalibration
from estimator.camera import CAMERA_MODELS, make_camera

MIRROR = {"model": "lookup", "width_px": 1280, "height_px": 1024, "cu_px": 640.0,
          "cv_px": 512.0, "calibration": {"model": "mirror", "a_m": 1.04,
                                          "b_rad_per_px": 0.002856}}


@pytest.mark.parametrize("name", CAMERA_MODELS)
def test_what_the_recorder_writes_parses_and_is_written_back_byte_for_byte(name: str) -> None:
    camera = make_camera(name)
    record = metadata.CamerasMetadata((metadata.CameraMetadata("robot1", camera.to_dict()),))
    text = record.to_metadata()
    assert text == {"robot1": metadata.json_text(camera.to_dict())}
    again = metadata.CamerasMetadata.from_metadata(text)
    assert again.to_metadata() == text
    spec = again.cameras[0].spec
    assert spec.model == name and spec.camera == camera
    assert spec.centre_px == camera.centre_px and spec.mount_yaw_rad == 0.0
    assert isinstance(spec.range_calibration, CameraCalibration)
    assert spec.calibration is None and spec.ball is None and spec.map_to_field is None


def test_a_lookup_camera_takes_its_range_from_its_calibration() -> None:
    spec = camera_spec_from_json(MIRROR, "f")
    assert spec.camera is None and spec.centre_px == (640.0, 512.0)
    assert spec.range_calibration == MirrorCalibration(1.04, 0.002856)


def test_the_optional_keys() -> None:
    spec = camera_spec_from_json({**MIRROR, "usable_radius_px": 500, "mount_yaw_deg": 90,
                                  "ball": "ball.json",
                                  "map_to_field": {"x_m": -9, "yaw_deg": 90}}, "f")
    assert spec.usable_radius_px == 500.0 and spec.mount_yaw_rad == pytest.approx(math.pi / 2)
    assert spec.ball == "ball.json"
    assert spec.map_to_field == FieldTransform(-9.0, 0.0, math.radians(90))
    inline = camera_spec_from_json({**MIRROR, "ball": {"hsv": [1, 2, 3]}}, "f")
    assert inline.ball == {"hsv": [1, 2, 3]}  # opaque: read by the ball model, later


def test_map_to_field_turns_then_moves() -> None:
    t = FieldTransform(-9.0, -6.0, math.pi / 2)
    x, y, yaw = t.apply(1.0, 0.0, 0.25)
    assert (x, y) == pytest.approx((-9.0, -5.0)) and yaw == pytest.approx(0.25 + math.pi / 2)


def test_the_paper_camera() -> None:
    assert PAPER_CAMERA.centre_px == (539.0, 539.0)
    assert PAPER_CAMERA.range_calibration == LinearCalibration(0.0163, 0.2786)


@pytest.mark.parametrize(("change", "message"), [
    ({"model": "pinhole"}, "robot1.model = 'pinhole' is not one of ideal, fisheye, mirror"),
    ({"model": None}, "robot1.model is missing: give one of ideal, fisheye, mirror, lookup"),
    ({"cu_px": "x"}, "robot1.cu_px = 'x' is not a number"),
    ({"cu_px": math.nan}, "robot1.cu_px = nan is not a finite number"),
    ({"cu_px": 1500.0}, "robot1.cu_px / cv_px = (1500, 512) is not inside the 1280 x 1024"),
    ({"width_px": 12.5}, "robot1.width_px = 12.5 is not a whole number of pixels"),
    ({"width_px": True}, "robot1.width_px = True is not a whole number"),
    ({"usable_radius_px": -3}, "robot1.usable_radius_px = -3 must be > 0"),
    ({"mount_yaw_deg": 720}, "robot1.mount_yaw_deg must be within [-360, 360]"),
    ({"zoom": 2}, "robot1.zoom is not a key of a lookup camera"),
    ({"calibration": {"model": "linear", "a_m_per_px": 1}},
     "robot1.calibration is unusable: calibration model 'linear' lacks the key 'b_m'"),
    ({"calibration": [1, 2]}, "robot1.calibration = [1, 2] is not an object"),
    ({"ball": 3}, "robot1.ball = 3 is neither a path nor an object"),
    ({"map_to_field": {"x": 1}}, "robot1.map_to_field has unknown key 'x'"),
    ({"map_to_field": {"yaw_deg": "n"}}, "robot1.map_to_field.yaw_deg = 'n' is not a number"),
])
def test_every_bad_field_is_one_line_naming_the_source_and_field(change: dict[str, Any],
                                                                  message: str) -> None:
    entry = {**MIRROR, **change}
    with pytest.raises(CameraDescriptionError) as err:
        camera_spec_from_json(entry, "cameras.yaml: robot1")
    assert str(err.value).startswith("cameras.yaml: ") and message in str(err.value)
    assert "\n" not in str(err.value)


def test_a_missing_key_is_named_with_what_the_model_needs() -> None:
    entry = {k: v for k, v in make_camera("mirror").to_dict().items() if k != "a_m"}
    with pytest.raises(CameraDescriptionError, match=r"robot1.a_m is missing: a mirror camera "
                       r"needs width_px, height_px, cu_px, cv_px, max_radius_px, height_m, a_m"):
        camera_spec_from_json(entry, "f: robot1")
    with pytest.raises(CameraDescriptionError, match=r"robot1\.calibration is missing"):
        camera_spec_from_json({k: v for k, v in MIRROR.items() if k != "calibration"},
                              "f: robot1")


def test_a_default_for_every_robot_and_robots_that_change_it() -> None:
    cams = camera_set_from_json({"default": MIRROR, "robot2": {"mount_yaw_deg": 90}}, "f")
    assert cams.for_robot("robot9") is cams.default and cams.default is not None
    robot2 = cams.for_robot("robot2")
    assert robot2 is not None and robot2.mount_yaw_rad == pytest.approx(math.pi / 2)
    assert robot2.range_calibration == cams.default.range_calibration
    only = camera_set_from_json({"robot1": MIRROR}, "f")
    assert only.for_robot("robot2") is None
    with pytest.raises(CameraDescriptionError, match="f: describes no camera"):
        camera_set_from_json({}, "f")


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_yaml_and_json_files_read_alike(tmp_path: Path) -> None:
    yml = _write(tmp_path, "c.yaml", camera_file_text({"default": MIRROR}, ".yaml",
                                                      header="a camera file"))
    jsn = _write(tmp_path, "c.json", camera_file_text({"default": MIRROR}, ".json"))
    assert yml.read_text().startswith("# a camera file\ndefault:\n")
    a, b = read_camera_file(yml), read_camera_file(jsn)
    assert a.default == b.default and a.default is not None
    assert a.default.entry == json.loads(jsn.read_text())["default"]


def test_yaml_reads_numbers_as_yaml_1_2_does(tmp_path: Path) -> None:
    text = ("default: {model: lookup, width_px: 100, height_px: 80, cu_px: 5e1, cv_px: 40,"
            " calibration: {model: linear, a_m_per_px: 1.63e-2, b_m: 0.2786}}\n")
    spec = read_camera_file(_write(tmp_path, "c.yml", text)).default
    assert spec is not None and spec.centre_px == (50.0, 40.0)


def test_a_relative_ball_path_is_the_camera_files_neighbour(tmp_path: Path) -> None:
    path = _write(tmp_path, "c.json", json.dumps({"default": {**MIRROR, "ball": "b.json"}}))
    spec = read_camera_file(path).default
    assert spec is not None and spec.ball == str(tmp_path / "b.json")


@pytest.mark.parametrize(("name", "text", "message"), [
    ("c.yaml", "default: &a {model: lookup}\nrobot1: *a\n", "an anchor"),
    ("c.yaml", "robot1: {}\nrobot1: {}\n", "the key 'robot1' is given twice"),
    ("c.yaml", "default: !!python/object/apply:os.system [ls]\n", "not valid YAML"),
    ("c.yaml", "default:\n  model: lookup\n  when: 2024-01-01\n", "date value"),
    ("c.yaml", "default: [unclosed\n", "not valid YAML"),
    ("c.json", '{"default": {"model": "lookup", "cu_px": NaN}}', "NaN is not a JSON number"),
    ("c.json", "[1, 2]", "[1, 2] is not an object"),
    ("c.txt", "{}", "a camera file ends in .yaml, .yml, .json"),
])
def test_bad_files_are_one_line_naming_the_file(tmp_path: Path, name: str, text: str,
                                                message: str) -> None:
    path = _write(tmp_path, name, text)
    with pytest.raises(CameraDescriptionError) as err:
        read_camera_file(path)
    assert str(err.value).startswith(str(path)) and message in str(err.value)
    assert "\n" not in str(err.value)


def test_a_file_is_bounded_and_regular(tmp_path: Path) -> None:
    big = _write(tmp_path, "big.yaml", "#" * (MAX_CAMERA_FILE_BYTES + 1))
    with pytest.raises(CameraDescriptionError, match="at most 1048576 bytes"):
        read_camera_file(big)
    folder = tmp_path / "folder.yaml"
    folder.mkdir()
    with pytest.raises(CameraDescriptionError, match="is a folder; give a camera file"):
        read_camera_file(folder)
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    with pytest.raises(CameraDescriptionError, match="not a regular file"):
        read_camera_file(fifo)
    with pytest.raises(CameraDescriptionError, match="cannot read"):
        read_camera_file(tmp_path / "missing.yaml")
    with pytest.raises(CameraDescriptionError, match="not UTF-8"):
        (tmp_path / "bin.yaml").write_bytes(b"\xff\xfe")
        read_camera_file(tmp_path / "bin.yaml")


def test_bad_camera_metadata_names_the_record_and_field() -> None:
    entry = {**make_camera("ideal").to_dict(), "cu_px": "middle"}
    with pytest.raises(metadata.MetadataError,
                       match=r"dsp.cameras: robot1.cu_px = 'middle' is not a number"):
        metadata.CamerasMetadata.from_metadata({"robot1": json.dumps(entry)})
    assert contract.CAMERAS_METADATA == "dsp.cameras"


FIELD_18X12 = {"length_m": 18.0, "width_m": 12.0, "goal_area_depth_m": 0.75,
               "goal_area_half_width_m": 1.75, "penalty_area_depth_m": 2.25,
               "penalty_area_half_width_m": 3.25, "centre_circle_radius_m": 2.0}


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_a_camera_file_names_its_field_by_name_or_dimensions(tmp_path: Path,
                                                             suffix: str) -> None:
    path = tmp_path / f"cams{suffix}"
    for given, name in (("18x12", "18x12"), ("22x14", "22x14"), ("msl", "22x14"),
                        (FIELD_18X12, "18x12"),
                        ({**FIELD_18X12, "length_m": 20.0, "width_m": 13.0},
                         "20x13 (described)")):
        path.write_text(camera_file_text({"default": MIRROR}, suffix, field=given))
        cams = read_camera_file(path)
        assert cams.field is not None and cams.field.name == name
        assert "field" not in cams.robots  # a key of the file, not a robot
        if isinstance(given, dict):
            assert cams.field.length_m == given["length_m"]
            assert cams.field.line_width_m == 0.125  # what is not given: FieldSpec's default
    path.write_text(camera_file_text({"default": MIRROR}, suffix))
    assert read_camera_file(path).field is None
    path.write_text(camera_file_text({}, suffix, field="18x12"))  # the log describes cameras
    only = read_camera_file(path)
    assert only.field is not None and only.default is None and not only.robots


@pytest.mark.parametrize(("field", "message"), [
    ("19x13", "field = '19x13' is not a field's name (known: 18x12, 22x14, msl (= 22x14))"),
    (None, "field is empty: name the field"),
    (18, "field = 18 is neither a field's name"),
    ({**FIELD_18X12, "length_m": -3}, "field.length_m = -3 must be > 0"),
    ({**FIELD_18X12, "length_m": "long"}, "field.length_m = 'long' is not a number"),
    ({**FIELD_18X12, "width_m": True}, "field.width_m = True is not a number"),
    ({**FIELD_18X12, "length_m": 1e6}, "field.length_m = 1e+06 is out of range: a field's "
     "sizes are at most 40 m"),
    ({**FIELD_18X12, "length_m": 10.0}, "field.width_m = 12 must be at most length_m (10)"),
    ({**FIELD_18X12, "penalty_area_depth_m": 9.5}, "field.penalty_area_depth_m = 9.5 must be "
     "at most half the length (9)"),
    ({**FIELD_18X12, "penalty_area_half_width_m": 7.0}, "field.penalty_area_half_width_m = 7 "
     "must be at most half the width (6)"),
    ({**FIELD_18X12, "goal_area_depth_m": 3.0}, "field.goal_area_depth_m = 3 must be at most "
     "penalty_area_depth_m (2.25): the goal area lies in the penalty area"),
    ({**FIELD_18X12, "colour": "green"}, "field.colour is not a key of a field"),
    ({"length_m": 18.0, "width_m": 12.0}, "field.goal_area_depth_m is missing"),
])
def test_a_bad_field_is_one_line_naming_the_file_and_key(tmp_path: Path, field: Any,
                                                         message: str) -> None:
    path = tmp_path / "cams.yaml"
    path.write_text(camera_file_text({"default": MIRROR}, ".yaml")
                    + f"field: {json.dumps(field)}\n")
    with pytest.raises(CameraDescriptionError) as err:
        read_camera_file(path)
    assert str(err.value).startswith(f"{path}: {message}") and "\n" not in str(err.value)
    assert err.value.exit_code == 2  # a bad camera entry exits 1
