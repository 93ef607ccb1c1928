"""The default replay chooses its ball detector from the log (replay.detector_choice): real
MSL camera images get the real-ball detector, simulated ones the colour chain, from their
pixels when the log states nothing, from its metadata when dsp-record wrote it; the choice
is printed and recorded, the same whatever the threads, and explicit options win."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer as RawWriter
from mcap_ros2.writer import Writer

from dsp import contract
from replay import detector_choice as dc
from replay import replay
from replay.cli import main
from replay.log import LogReader
from replay.profiles import options_for

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = ROOT / "logs" / "golden"
MSL = ROOT / "tests" / "data" / "msl-images" / "20220715" / "r7"
NS = 1_000_000_000


def _camera(width: int, height: int) -> dict[str, object]:
    return {"model": "lookup", "width_px": width, "height_px": height,
            "cu_px": (width - 1) / 2, "cv_px": (height - 1) / 2,
            "calibration": {"model": "linear", "a_m_per_px": 0.02, "b_m": 0.1}}


def write_image_log(path: Path, images: dict[str, list[bytes]], *, size: tuple[int, int],
                    rate_hz: float = 4.0) -> Path:
    """A robot's kind of log of the given JPEG images: each robot's at ``rate_hz`` (robot k
    a little later than robot k - 1), its pose standing still at 50 Hz, a camera
    description, and no dsp.scenario or dsp.recorder metadata."""
    dt = round(NS / rate_hz)
    end = max(len(v) for v in images.values()) * dt + dt
    events: list[tuple[int, int, str, int]] = []
    for k, robot in enumerate(images):
        events += [(t, 0, robot, -1) for t in range(0, end, NS // 50)]
        events += [(i * dt + k * 7_000_000 + 1_000_000, 1, robot, i)
                   for i in range(len(images[robot]))]
    with path.open("wb") as f:
        w = Writer(f)
        schemas = {n: w.register_msgdef(n, t) for n, t in contract.MESSAGE_DEFINITIONS.items()}
        w.add_metadata(contract.CAMERAS_METADATA,
                       {r: json.dumps(_camera(*size), sort_keys=True) for r in images})
        for k, (t, kind, robot, i) in enumerate(sorted(events)):
            header = {"stamp": contract.stamp_from_ns(t), "frame_id": contract.FIELD_FRAME}
            if kind == 0:
                pose = {"position": {"x": -2.0 + list(images).index(robot), "y": 0.0, "z": 0.0},
                        "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
                w.write_message(contract.topic_for(contract.POSE_TOPIC, robot),
                                schemas[contract.POSE_STAMPED], {"header": header, "pose": pose},
                                log_time=t, publish_time=t, sequence=k)
            else:
                header["frame_id"] = contract.camera_frame(robot)
                w.write_message(contract.topic_for(contract.IMAGE_TOPIC, robot),
                                schemas[contract.COMPRESSED_IMAGE],
                                {"header": header, "format": "jpeg", "data": images[robot][i]},
                                log_time=t, publish_time=t, sequence=k)
        w.finish()
    return path


def _msl_log(tmp_path: Path, blind: dict[str, int] | None = None, *,
             name: str = "msl.mcap") -> Path:
    """Two robots of the real images (7 each, at 4 Hz); ``blind={"robot3": n}`` adds a
    robot whose camera shows a grey wall in its first n images, then (n > 0) the ball in 4
    more, or (n < 0) the wall in -n images and no ball."""
    jpgs = [p.read_bytes() for p in sorted(MSL.glob("*.jpg"))]
    images = {"robot1": jpgs[0::2], "robot2": jpgs[1::2]}
    for robot, n in (blind or {}).items():
        ok, buf = cv2.imencode(".jpg", np.full((800, 608, 3), 90, np.uint8))
        assert ok
        images[robot] = [buf.tobytes()] * abs(n) + (jpgs[:4] if n > 0 else [])
    return write_image_log(tmp_path / name, images, size=(608, 800))


def rewrite_metadata(src: Path, dst: Path,
                     edit: Callable[[str, dict[str, str]], dict[str, str] | None]) -> Path:
    """``src`` with each metadata record replaced by ``edit(name, record)`` (None: left
    out); the messages as they were."""
    with src.open("rb") as f_in, dst.open("wb") as f_out:
        reader = make_reader(f_in)
        out = RawWriter(f_out)
        out.start(profile="ros2", library="test")
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            assert schema is not None
            if schema.id not in schema_ids:
                schema_ids[schema.id] = out.register_schema(schema.name, schema.encoding,
                                                            schema.data)
            if channel.id not in channel_ids:
                channel_ids[channel.id] = out.register_channel(
                    channel.topic, channel.message_encoding, schema_ids[schema.id],
                    dict(channel.metadata))
            out.add_message(channel_ids[channel.id], message.log_time, message.data,
                            message.publish_time, message.sequence)
        f_in.seek(0)
        for record in make_reader(f_in).iter_metadata():
            kept = edit(record.name, dict(record.metadata))
            if kept is not None:
                out.add_metadata(record.name, kept)
        out.finish()
    return dst


def strip_dsp_metadata(src: Path, dst: Path) -> Path:
    """``src`` without its dsp.scenario and dsp.recorder records (its cameras kept, as a
    team's camera description): a simulated log that states neither its ball nor who
    rendered it."""
    return rewrite_metadata(src, dst, lambda name, record: (
        record if name == contract.CAMERAS_METADATA else None))


def _replay(log: Path, out: Path, **given: object) -> dict[str, object]:
    replay(log, options_for(out=out, progress=False, **given))
    doc: dict[str, object] = json.loads(out.read_text())
    return doc


def test_real_camera_images_get_the_real_detector_and_the_choice_is_recorded(
        tmp_path: Path) -> None:
    log = _msl_log(tmp_path)
    with LogReader(log) as reader:
        found = dc.probe(reader, options_for())
    assert found.images == {"robot1": 7, "robot2": 7}
    # Bangkok's yellow ball and yellow shirts give the colour chain round blobs in about
    # half of these images: its hardest venue, and still well behind
    assert found.total("real") >= 12 and found.total("paper") <= found.total("real") - 5, found
    doc = _replay(log, tmp_path / "r.json")
    pipeline = doc["pipeline"]
    assert isinstance(pipeline, dict) and pipeline["detector"] == "real"
    assert "the real detector (generic model) finds a clear ball in robot1" in str(
        pipeline["detector_choice"])
    options = doc["options"]
    assert isinstance(options, dict)
    assert (options["detector"], options["ball"]) == ("real", "ball_generic.json")


def test_the_choice_is_the_same_bytes_whatever_the_threads(tmp_path: Path) -> None:
    log = _msl_log(tmp_path)
    texts = []
    for threads in (1, 2):
        out = tmp_path / f"t{threads}.json"
        replay(log, options_for(out=out, progress=False, threads=threads))
        texts.append(out.read_bytes())
    assert texts[0] == texts[1]


def test_a_simulated_log_without_its_metadata_gets_the_colour_chain_from_its_images(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = strip_dsp_metadata(GOLDEN / "scenario2.mcap", tmp_path / "team.mcap")
    with LogReader(log) as reader:
        assert reader.info.scenario is None and reader.info.recorder is None
        found = dc.probe(reader, options_for())
    assert found.total("paper") > found.total("real"), found
    out = tmp_path / "r.json"
    assert main([str(log), "--out", str(out)]) == 0
    line = capsys.readouterr().out.splitlines()[0]
    assert line.startswith("pipeline (best): paper detector (chosen: in its first images the "
                           "colour chain finds a clear ball in robot1 2/2, robot2 2/2, robot3 "
                           "2/2, the real detector (generic model) in robot1 0/2"), line
    pipeline = json.loads(out.read_text())["pipeline"]
    assert pipeline["detector"] == "paper"
    assert pipeline["detector_choice"].startswith("in its first images the colour chain")


def test_a_dsp_record_log_gets_the_colour_chain_from_its_metadata_without_probing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def no_probe(*_: object) -> None:
        raise AssertionError("probed a log whose metadata states its ball")

    monkeypatch.setattr(dc, "probe", no_probe)
    doc = _replay(GOLDEN / "rolling.mcap", tmp_path / "r.json")
    assert doc["pipeline"] == json.loads(
        (GOLDEN / "rolling.profile-best.json").read_text())["pipeline"]  # nothing more


def test_a_dsp_record_log_of_another_ball_is_left_to_its_images(tmp_path: Path) -> None:
    """The metadata says yellow (the images show the orange ball): the colour chain is not
    taken on the metadata's word, the images are probed, and they choose it."""
    def yellow(name: str, record: dict[str, str]) -> dict[str, str]:
        if name != contract.SCENARIO_METADATA:
            return record
        params = json.loads(record["params"])
        params["recording"]["ball_colour"] = "yellow"
        return {**record, "params": json.dumps(params, sort_keys=True)}

    log = rewrite_metadata(GOLDEN / "rolling.mcap", tmp_path / "yellow.mcap", yellow)
    with LogReader(log) as reader:
        recording = reader.info.scenario.recording if reader.info.scenario else None
        assert recording is not None and recording.ball_colour == "yellow"
    pipeline = _replay(log, tmp_path / "r.json")["pipeline"]
    assert isinstance(pipeline, dict) and pipeline["detector"] == "paper"
    assert str(pipeline["detector_choice"]).startswith(
        "the log's ball is yellow, not the colour chain's orange; in its first images the "
        "colour chain finds a clear ball in robot1 ")


def test_explicit_options_and_the_paper_method_keep_their_detector(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = _msl_log(tmp_path)

    def no_probe(*_: object) -> None:
        raise AssertionError("probed although the options chose the detector")

    monkeypatch.setattr(dc, "probe", no_probe)
    for given in ({"detector": "paper"}, {"method": "paper"}):
        pipeline = _replay(log, tmp_path / "p.json", force=True, **given)["pipeline"]
        assert isinstance(pipeline, dict) and pipeline["detector"] == "paper"
        assert "detector_choice" not in pipeline
    replay(log, options_for("paper", out=tmp_path / "paper.json", progress=False))
    assert json.loads((tmp_path / "paper.json").read_text())["pipeline"]["detector"] == "paper"
    ball = tmp_path / "venue.json"
    shutil.copyfile(dc.generic_ball_path(), ball)
    doc = _replay(log, tmp_path / "b.json", detector="real", ball=ball)
    assert doc["pipeline"]["detector"] == "real" and "detector_choice" not in doc["pipeline"]
    assert doc["options"]["ball"] == "venue.json"


def test_a_camera_file_s_ball_model_is_the_real_detector_s(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = _msl_log(tmp_path)
    shutil.copyfile(dc.generic_ball_path(), tmp_path / "venue.json")
    cameras = tmp_path / "cameras.json"
    cameras.write_text(json.dumps({"default": {**_camera(608, 800), "ball": "venue.json"}}))
    monkeypatch.setattr(dc, "probe", lambda *_: pytest.fail("probed"))
    doc = _replay(log, tmp_path / "r.json", cameras=cameras)
    assert doc["pipeline"]["detector"] == "real"
    assert "names the ball model venue.json" in doc["pipeline"]["detector_choice"]
    assert doc["options"]["ball"] == "venue.json"


def test_a_camera_file_s_inline_ball_model_is_used_as_its_file_would_be(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = _msl_log(tmp_path)
    venue = json.loads(dc.generic_ball_path().read_text())
    venue["threshold"] = min(0.99, venue["threshold"] + 0.3)  # not the generic model's
    (tmp_path / "venue.json").write_text(json.dumps(venue))
    by_file, inline = tmp_path / "file.json", tmp_path / "inline.json"
    by_file.write_text(json.dumps({"default": {**_camera(608, 800), "ball": "venue.json"}}))
    inline.write_text(json.dumps({"default": {**_camera(608, 800), "ball": venue}}))
    monkeypatch.setattr(dc, "probe", lambda *_: pytest.fail("probed"))
    generic = _replay(log, tmp_path / "g.json", detector="real")
    for k, given in enumerate(({}, {"detector": "real"})):
        a = _replay(log, tmp_path / f"a{k}.json", cameras=by_file, **given)
        b = _replay(log, tmp_path / f"b{k}.json", cameras=inline, **given)
        assert b["pipeline"]["detector"] == "real"  # type: ignore[index]
        assert "robot1's ball model inline" in b["pipeline"]["detector_choice"]  # type: ignore[index]
        assert a["frames"] == b["frames"] != generic["frames"]


def test_an_inline_ball_model_that_is_none_is_one_line_naming_the_file_and_robot(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = _msl_log(tmp_path)
    cameras = tmp_path / "cameras.json"
    cameras.write_text(json.dumps({"default": {**_camera(608, 800), "ball": {"format": "x"}}}))
    code = main([str(log), "--cameras", str(cameras), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 1 and err.strip().splitlines() == [
        f"dsp-replay: error: {cameras}: robot1.ball: not a ball model: 'format' must be "
        "'dual-sight ball model'"], err


def test_a_robot_the_chosen_detector_finds_no_ball_for_is_named(tmp_path: Path) -> None:
    # blind in the probe's first 5 s (20 images at 4 Hz), the ball later: the probe says so
    summary = replay(_msl_log(tmp_path, blind={"robot3": 22}), options_for(progress=False))
    assert summary.pipeline is not None and summary.pipeline.startswith(
        "pipeline (best): real detector (chosen:")
    named = [w for w in summary.warnings if "robot3" in w]
    assert len(named) == 1 and "robot3 shows no clear ball in its 20 first images" in named[0]
    # blind all along: the whole replay's warning names it, once
    summary = replay(_msl_log(tmp_path, blind={"robot3": -6}, name="blind.mcap"),
                     options_for(progress=False))
    named = [w for w in summary.warnings if "robot3" in w]
    assert len(named) == 1 and "robot3 saw the ball in none" in named[0], named


def test_a_robot_whose_balls_the_others_do_not_agree_with_is_named(tmp_path: Path) -> None:
    """robot3 believes itself 1.5 m from where it is: its balls land 1.5 m off the others'.
    In a short log the probe says so; in a longer one the whole replay does, once."""
    from synthetic import write_log

    log = tmp_path / "bias.mcap"
    write_log(log, duration_s=0.5, pose_bias_m={"robot3": (1.5, 0.0)})
    summary = replay(log, options_for(progress=False))
    assert summary.pipeline is not None
    assert "; 6 of the 9 balls agree with another robot's on the field" in summary.pipeline
    assert summary.warnings == (
        f"{log}: none of the 3 balls the paper detector finds in robot3's first images "
        "agrees with another robot's (within 0.5 m, 0.1 s): is its pose, its camera "
        "description or what the detector takes for the ball wrong?",)
    long = tmp_path / "long.mcap"
    write_log(long, duration_s=1.5, pose_bias_m={"robot3": (1.5, 0.0)})
    assert replay(long, options_for(progress=False)).warnings == (
        f"{long}: none of the 16 balls robot3 placed on the field agrees with another "
        "robot's placed at nearly the same time (within 0.5 m, 0.1 s): is its pose or its "
        "camera description wrong, or does the paper detector take something else for the "
        "ball?",)
