"""Golden logs (logs/golden/): replay reproduces the expected outputs, the logs are pinned.

The goldens and their constants come from ``scripts/make_golden.py`` (loaded by path, so it
works from a fresh clone with ``python -m pytest`` at the repo root). To regenerate them
after a deliberate change: ``python scripts/make_golden.py --force`` and say why in the
commit.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import cv2
import pytest

from dsp import contract as c
from replay import ReplayOptions, RerunTarget, replay

ROOT = Path(__file__).resolve().parents[2]


def _load_make_golden() -> ModuleType:
    name = "make_golden"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / "make_golden.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses and pickling look modules up by name
    spec.loader.exec_module(module)
    return module


mg = _load_make_golden()
SCENES = list(mg.SCENES)
CONFIGS = list(mg.CONFIGS)
CASES = [(scene, m, f) for scene in SCENES for m, f in mg.scene_configs(scene)]
"""Every (scene, method, fusion) with an expected file: CONFIGS, and a scene's extras."""
MAX_FOLDER_BYTES = 10_000_000
# the far ball (worst renderer gap), a moving scene and a ball in the air
RERECORD = ("scenario1", "rolling", "lobs")


@pytest.fixture(scope="module")
def manifest() -> dict[str, Any]:
    return mg.load_manifest()


def _log(scene: str) -> Path:
    return mg.GOLDEN_DIR / mg.log_name(scene)


def _expected_text(scene: str, method: str, fusion: str) -> str:
    return (mg.GOLDEN_DIR / mg.expected_name(scene, method, fusion)).read_text(encoding="ascii")


def _expected(scene: str, method: str, fusion: str) -> dict[str, Any]:
    doc: dict[str, Any] = json.loads(_expected_text(scene, method, fusion))
    return doc


@pytest.fixture
def restore_cv2_threads() -> Iterator[None]:
    before = cv2.getNumThreads()
    try:
        yield
    finally:
        cv2.setNumThreads(before)


# --- the golden set itself -----------------------------------------------------------------


def test_manifest_matches_the_script(manifest: dict[str, Any]) -> None:
    assert manifest["format"] == mg.MANIFEST_FORMAT
    assert manifest["version"] == mg.MANIFEST_VERSION
    assert manifest["renderer"] == mg.RENDERER
    assert [(d["method"], d["fusion"]) for d in manifest["configs"]] == CONFIGS
    assert {scene: [(d["method"], d["fusion"]) for d in pairs]
            for scene, pairs in manifest["extra_configs"].items()} == {
        scene: list(pairs) for scene, pairs in mg.EXTRA_CONFIGS.items()}
    assert set(mg.EXTRA_CONFIGS) <= set(SCENES)
    assert list(manifest["scenes"]) == sorted(SCENES)
    for scene, entry in manifest["scenes"].items():
        assert entry["expected"] == {mg.config_label(m, f): mg.expected_name(scene, m, f)
                                     for m, f in mg.scene_configs(scene)}
        assert entry["record"] == {**mg.SCENES[scene], "renderer": mg.RENDERER}
        assert entry["renderer"] == mg.RENDERER
        assert entry["robots"] == 3 and entry["record"]["camera"] == "ideal"
        assert entry["message_count"] == sum(entry["topics"].values())
    written = {p.name for p in mg.GOLDEN_DIR.iterdir() if p.is_file()}
    assert {p.name for p in mg.targets()} <= written
    size = sum(p.stat().st_size for p in mg.GOLDEN_DIR.rglob("*") if p.is_file())
    assert size < MAX_FOLDER_BYTES, f"logs/golden is {size} bytes"


@pytest.mark.parametrize("scene", SCENES)
def test_log_bytes_are_pinned(scene: str, manifest: dict[str, Any]) -> None:
    entry = manifest["scenes"][scene]
    assert _log(scene).stat().st_size == entry["bytes"]
    assert mg.sha256_of(_log(scene)) == entry["sha256"], (
        f"{_log(scene)} changed; if deliberate, regenerate with make_golden.py --force")


def test_make_golden_refuses_to_overwrite(capsys: pytest.CaptureFixture[str]) -> None:
    assert all(p.exists() for p in mg.targets())  # else generate() would record them
    before = {p: p.stat().st_mtime_ns for p in mg.targets()}
    with pytest.raises(FileExistsError, match="--force"):
        mg.generate(force=False)
    with pytest.raises(FileExistsError, match="--force"):
        mg.generate(force=False, expected_only=True)
    assert mg.main([]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--force" in err
    assert mg.main(["--expected-only"]) == 2
    assert "--force" in capsys.readouterr().err
    assert mg.main(["--scene", "lobs"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--force" in err and "lobs.mcap" in err
    with pytest.raises(ValueError, match="unknown golden scene 'nope'"):
        mg.generate(force=True, scene="nope")
    assert {p: p.stat().st_mtime_ns for p in mg.targets()} == before


def test_one_scene_is_regenerated_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--force --expected-only --scene lobs`` on a copy of the goldens rewrites the lob's
    expected files and the manifest only, to the same bytes: every other file is not even
    touched, and the other scenes' manifest entries are kept as they are."""
    copy = tmp_path / "golden"
    shutil.copytree(mg.GOLDEN_DIR, copy, ignore=shutil.ignore_patterns("images-*"))
    before = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in copy.iterdir()}
    monkeypatch.setattr(mg, "GOLDEN_DIR", copy)
    mg.generate(force=True, expected_only=True, scene="lobs")
    after = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in copy.iterdir()}
    assert set(after) == set(before)  # nothing left behind (the work folder is gone)
    rewritten = {mg.MANIFEST, *(mg.expected_name("lobs", m, f)
                                for m, f in mg.scene_configs("lobs"))}
    assert {n for n in after if after[n][1] != before[n][1]} == rewritten
    assert all(after[n][0] == before[n][0] for n in after)  # the same bytes


FRAME_FIELDS = {"frame", "robot", "stamp_ns", "t_s", "status", "detection", "pose", "estimate",
                "truth", "error_m"}
STEP_FIELDS = {"step", "stamp_ns", "t_s", "robots", "fused_robots", "x_m", "y_m", "covariance",
               "truth", "error_m"}


@pytest.mark.parametrize("scene", SCENES)
def test_expected_files_hold_every_field(scene: str, manifest: dict[str, Any]) -> None:
    """The expected files are whole results files: poses, truth, errors, bbox, circularity
    and the summary's mean errors are pinned too, at the results file's precision."""
    doc = _expected(scene, "corrected", "weighted")
    assert {"format", "version", "log", "options", "frames", "fused", "summary"} <= set(doc)
    assert len(doc["log"]["sha256"]) == 64
    assert all(set(f) == FRAME_FIELDS for f in doc["frames"])
    # a log with the ball's true velocity (match, lobs) adds it to every step
    odometry = c.GT_BALL_ODOMETRY_TOPIC in manifest["scenes"][scene]["topics"]
    velocity = {"truth_velocity_m_s"} if odometry else set()
    assert all(set(s) == STEP_FIELDS | velocity for s in doc["fused"])
    ok = [f for f in doc["frames"] if f["status"] == "ok"]
    assert ok and all(f["pose"] and f["truth"] and f["error_m"] is not None for f in ok)
    assert all({"bbox_px", "circularity"} <= set(f["detection"]) for f in ok)
    assert all(s["truth"] is not None for s in doc["fused"])
    # floats as replay writes them (6 decimals), not rounded further
    assert any(len(repr(f["estimate"]["x_m"]).split(".")[-1]) == 6 for f in ok)


def test_the_lob_golden_holds_a_ball_in_the_air_seen_by_two_robots() -> None:
    """The lob scene pins the 3-D fusions where they matter: steps with the ball well off
    the ground whose rays two robots crossed, the height found, a landing predicted."""
    steps = _expected("lobs", "corrected", "triangulate")["fused"]
    flying = [s for s in steps if s["truth_z_m"] > 0.3]
    assert len(flying) >= 2
    assert all(s["triangulated"] and len(s["fused_robots"]) >= 2 for s in flying)
    assert all(abs(s["z_m"] - s["truth_z_m"]) < 0.05 for s in flying)
    track = _expected("lobs", "corrected", "ballistic")["fused"]
    assert any(s["landing"] is not None for s in track)
    assert all(s["z_m"] > 0.3 for s, t in zip(track, steps, strict=True) if t in flying)


# --- replay reproduces the expected outputs ------------------------------------------------


@pytest.mark.parametrize(("scene", "method", "fusion"), CASES,
                         ids=[f"{s}-{mg.config_label(m, f)}" for s, m, f in CASES])
def test_replay_reproduces_the_golden_output(scene: str, method: str, fusion: str,
                                             tmp_path: Path) -> None:
    text = mg.replay_text(_log(scene), method, fusion, tmp_path)
    assert json.loads(text) == _expected(scene, method, fusion)  # every field, exactly
    assert text == _expected_text(scene, method, fusion)  # and the same bytes


@pytest.mark.parametrize(("method", "fusion"), [("paper", "mean"), ("corrected", "weighted")])
@pytest.mark.parametrize("scene", ["scenario1", "rolling"])
def test_results_file_is_byte_identical_across_runs_and_threads(
        scene: str, method: str, fusion: str, tmp_path: Path, restore_cv2_threads: None) -> None:
    outputs = []
    for run, threads in enumerate((None, None, 1, 2)):  # default twice, then 1 and 2 threads
        if threads is not None:
            cv2.setNumThreads(threads)
        out = tmp_path / f"run{run}" / "results.json"
        out.parent.mkdir()
        replay(_log(scene), ReplayOptions(method=method, fusion=fusion, out=out,
                                          progress=False))
        outputs.append(out.read_bytes())
    assert all(o == outputs[0] for o in outputs[1:])
    assert json.loads(outputs[0]) == _expected(scene, method, fusion)
    assert outputs[0].decode("ascii") == _expected_text(scene, method, fusion)


@pytest.mark.parametrize(("scene", "method", "fusion"),
                         [("scenario2", "paper", "mean"), ("rolling", "corrected", "weighted")])
def test_rrd_holds_the_golden_scene(scene: str, method: str, fusion: str,
                                    tmp_path: Path) -> None:
    from rerun.chunk import RrdReader

    rrd = tmp_path / f"{scene}.rrd"
    replay(_log(scene), ReplayOptions(method=method, fusion=fusion, progress=False,
                                      rerun=RerunTarget("save", str(rrd))))
    chunks = RrdReader(rrd).stream().to_chunks()
    entities = {ch.entity_path for ch in chunks}
    golden = _expected(scene, method, fusion)

    def rows(entity: str, component: str) -> dict[int, Any]:
        """frame (or step) index -> the component's value, for one entity."""
        out: dict[int, Any] = {}
        for ch in chunks:
            if ch.entity_path != entity:
                continue
            rb = ch.to_record_batch()
            if component not in rb.schema.names:
                continue
            index = "step" if "step" in rb.schema.names else "frame"
            for i, v in zip(rb.column(index).to_pylist(), rb.column(component).to_pylist(),
                            strict=True):
                if v:
                    out[i] = v
        return out

    assert "/field/fused" in entities
    fused = rows("/field/fused", "Points3D:positions")
    want_fused = {s["step"]: s for s in golden["fused"] if s["x_m"] is not None}
    assert set(fused) == set(want_fused)
    for step, ((x, y, _z),) in fused.items():
        assert (x, y) == pytest.approx((want_fused[step]["x_m"], want_fused[step]["y_m"]),
                                       abs=mg.TOLERANCES["rrd_position_m"])
    for robot in golden["log"]["robots"]:
        frames = {f["frame"]: f for f in golden["frames"] if f["robot"] == robot}
        assert f"/robots/{robot}/camera/image" in entities
        detected = {i: f["detection"] for i, f in frames.items() if f["detection"]}
        estimated = {i: f["estimate"] for i, f in frames.items() if f["estimate"]}
        centroid = f"/robots/{robot}/camera/detection/centroid"
        estimate = f"/field/robots/{robot}/estimate"
        if not detected:  # rolling: the goalkeeper never sees the ball
            assert centroid not in entities
            continue
        assert centroid in entities and estimate in entities
        got = rows(centroid, "Points2D:positions")
        assert set(got) == set(detected)
        for i, ((cx, cy),) in got.items():
            assert (cx, cy) == pytest.approx((detected[i]["cx_px"], detected[i]["cy_px"]),
                                             abs=mg.TOLERANCES["rrd_centroid_px"])
        points = rows(estimate, "Points3D:positions")
        assert set(points) == set(estimated)
        for i, ((x, y, _z),) in points.items():
            assert (x, y) == pytest.approx((estimated[i]["x_m"], estimated[i]["y_m"]),
                                           abs=mg.TOLERANCES["rrd_position_m"])


# --- independent readers -------------------------------------------------------------------


@pytest.mark.parametrize("scene", SCENES)
def test_rosbags_reads_the_golden_log(scene: str, manifest: dict[str, Any]) -> None:
    from rosbags.highlevel import AnyReader

    want = manifest["scenes"][scene]["topics"]
    with AnyReader([_log(scene)]) as reader:
        types = {conn.topic: conn.msgtype for conn in reader.connections}
        assert set(types) == set(want)
        assert types["/robot1/omni/image/compressed"] == c.COMPRESSED_IMAGE
        assert types["/tf"] == c.TF_MESSAGE
        assert types["/ground_truth/ball"] == c.POSE_STAMPED
        counts: dict[str, int] = {}
        last: dict[str, Any] = {}
        for conn, _t, raw in reader.messages():
            counts[conn.topic] = counts.get(conn.topic, 0) + 1
            last[conn.msgtype] = (conn, raw)
        assert counts == want
        assert reader.message_count == manifest["scenes"][scene]["message_count"]
        for msgtype, (_conn, raw) in last.items():  # each type deserialises
            msg = reader.deserialize(raw, msgtype)
            if msgtype == c.COMPRESSED_IMAGE:
                assert msg.format == "png" and len(msg.data) > 0


@pytest.mark.parametrize("scene", SCENES)
def test_rerun_mcap_loader_reads_the_golden_log(scene: str, manifest: dict[str, Any]) -> None:
    from rerun.chunk import McapReader

    entry = manifest["scenes"][scene]
    reader = McapReader(_log(scene), timeline_type="duration_ns")
    assert reader.info().message_count == entry["message_count"]
    columns: dict[str, set[str]] = {}
    for chunk in reader.stream():
        names = {f.name for f in chunk.to_record_batch().schema}
        columns.setdefault(chunk.entity_path, set()).update(names)
    assert set(entry["topics"]) <= set(columns)
    for robot in ("robot1", "robot2", "robot3"):
        assert "EncodedImage:blob" in columns[c.topic_for(c.IMAGE_TOPIC, robot)]
        assert "InstancePoses3D:translations" in columns[c.topic_for(c.POSE_TOPIC, robot)]
    assert "Transform3D:translation" in columns[c.TF_TOPIC]


# --- re-recording on this machine ----------------------------------------------------------


@pytest.mark.parametrize("scene", RERECORD)
def test_rerecorded_scene_detects_within_tolerance(scene: str, tmp_path: Path,
                                                   manifest: dict[str, Any]) -> None:
    from recorder.record import RecordOptions, record

    log = tmp_path / mg.log_name(scene)
    # "auto": EGL when it loads, else TinyRenderer; DSP_RENDERER overrides it
    summary = record(log, RecordOptions(renderer="auto", **mg.SCENES[scene]))
    same = summary.renderer == manifest["renderer"]
    tol = mg.TOLERANCES["detection_same_renderer_px" if same else "detection_other_renderer_px"]
    got = mg.replay_results(log, "corrected", "weighted", tmp_path)
    want = _expected(scene, "corrected", "weighted")
    assert [(f["robot"], f["stamp_ns"], f["status"]) for f in got["frames"]] == [
        (f["robot"], f["stamp_ns"], f["status"]) for f in want["frames"]]
    worst = 0.0
    for g, w in zip(got["frames"], want["frames"], strict=True):
        if w["detection"] is not None:
            worst = max(worst, *(abs(g["detection"][k] - w["detection"][k])
                                 for k in ("cx_px", "cy_px")))
    assert worst <= tol, (
        f"{scene} re-recorded with {summary.renderer}: a centroid moved {worst:.3f} px "
        f"from the {manifest['renderer']} golden (tolerance {tol} px)")
