"""The Rerun recording as docs/viewer.md lists it: a saved .rrd, read back with rerun's own
reader, has exactly the documented entities on the documented timelines, no wall clock, and
gaps (Clear) in its plots where there is no value."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from replay.beliefs import describe_belief
from replay.options import ReplayOptions, RerunTarget
from replay.profiles import options_for
from replay.runner import replay
from replay.sinks.rerun.shapes import label_box
from replay.sinks.rerun.sink import ENTITY_PATHS, LOCALISED_PATHS, TIMELINES

chunk = pytest.importorskip("rerun.chunk")
ROOT = Path(__file__).resolve().parents[4]
DOC = (ROOT / "docs" / "viewer.md").read_text()
ROBOTS = ("robot1", "robot2", "robot3")
HEIGHTS = {"/field/fused/height", "/plots/height/fused", "/plots/height/truth"}
"""Logged only by a 3-D fusion (``triangulate``)."""


def _documented() -> dict[str, set[str]]:
    """Entity path -> its timelines (empty: static), from the doc's Entities table."""
    rows = re.findall(r"^\| `(/[^`]+)` \| \w+ \| ([^|]+) \|", DOC, flags=re.MULTILINE)
    return {path: set() if when.strip() == "static" else
            {t.strip() for t in when.split(",")} for path, when in rows}


@pytest.fixture(scope="module")
def chunks(tmp_path_factory: pytest.TempPathFactory) -> list[object]:
    rrd = tmp_path_factory.mktemp("rrd") / "rolling.rrd"
    replay(ROOT / "logs" / "golden" / "rolling.mcap",
           ReplayOptions(rerun=RerunTarget("save", str(rrd)), progress=False))
    reader = chunk.RrdReader(rrd)
    assert [r.application_id for r in reader.recordings()] == ["dual_sight_replay"]
    assert reader.blueprints(), "the recording carries its layout"
    return list(reader.stream())


def test_the_doc_lists_exactly_the_sinks_entities() -> None:
    documented = _documented()
    assert list(documented) == list(ENTITY_PATHS)
    timelines = set().union(*documented.values())
    assert timelines == set(TIMELINES)
    assert re.findall(r"^\| `(\w+)` \| (?:duration|sequence)", DOC, re.MULTILINE) == list(TIMELINES)


def _pattern(path: str) -> re.Pattern[str]:
    return re.compile("^" + re.escape(path).replace(r"\{robot\}", "(robot[0-9]+)") + "$")


def test_every_entity_in_the_rrd_is_documented_on_its_timelines(chunks: list) -> None:
    documented = _documented()
    patterns = [(_pattern(p), p) for p in documented]
    seen: set[str] = set()
    for ch in chunks:
        path = ch.entity_path
        if path == "/__properties":
            continue
        match = [doc for rx, doc in patterns if rx.match(path)]
        assert match, f"{path} is not in docs/viewer.md"
        seen.add(match[0])
        if ch.is_static:
            # static: documented as such, or a plot's name and colour
            assert not documented[match[0]] or path.startswith("/plots/"), path
            assert ch.timeline_names == []
        else:
            assert set(ch.timeline_names) == documented[match[0]], path
    assert "log_time" not in {t for ch in chunks for t in ch.timeline_names}
    # the default fusion tracks the ball: every documented entity is there but the Clear of
    # a track that never was lost, the real detector's candidates (the paper's chain here),
    # what only --localise lines logs, the heights only a 3-D fusion logs and the landing
    # only ballistic predicts
    assert set(documented) - seen <= {"/field/track", "/robots/{robot}/camera/candidates",
                                      "/field/track/landing", *LOCALISED_PATHS} | HEIGHTS
    assert {"/field/track/trail", "/field/track/velocity"} <= seen


def test_a_robot_that_never_sees_the_ball_has_gaps_not_values(chunks: list) -> None:
    def columns(path: str) -> set[str]:
        return {name for ch in chunks if ch.entity_path == path and not ch.is_static
                for name in ch.to_record_batch().schema.names}

    # in the rolling log robot1 never sees the ball; robot2 always does
    assert "Clear:is_recursive" in columns("/plots/error/robot1")
    assert "Scalars:scalars" not in columns("/plots/error/robot1")
    assert "Scalars:scalars" in columns("/plots/error/robot2")
    assert "Clear:is_recursive" not in columns("/plots/error/robot2")
    for robot in ROBOTS:
        assert columns(f"/robots/{robot}/camera/image")
    # the tracker's speed (the golden log predates the true velocity: no truth speed)
    assert "Scalars:scalars" in columns("/plots/speed/track")
    assert not columns("/plots/speed/truth")


def test_the_real_detector_logs_its_candidates_under_the_camera(
        tmp_path: Path) -> None:
    from replay.calibrate.cli import main as calibrate

    ball = tmp_path / "ball.json"
    subset = ROOT / "tests" / "data" / "msl-images" / "20220715" / "r7"
    assert calibrate(["--ball-from", str(subset), "--train-count", "10", "-o", str(ball),
                      "-q"]) == 0
    rrd = tmp_path / "real.rrd"
    replay(ROOT / "logs" / "golden" / "match.mcap",
           ReplayOptions(ball=ball, rerun=RerunTarget("save", str(rrd)), progress=False))
    found = [ch for ch in chunk.RrdReader(rrd).stream()
             if _pattern("/robots/{robot}/camera/candidates").match(ch.entity_path)]
    assert found and all(set(ch.timeline_names) == {"sim_time", "frame"} for ch in found)
    names = {n for ch in found for n in ch.to_record_batch().schema.names}
    assert any("Boxes2D:half_sizes" in n for n in names), names
    assert any("Boxes2D:labels" in n for n in names), names


def test_a_3d_fusion_shows_the_ball_s_height(tmp_path: Path) -> None:
    """--fusion triangulate: the fused ball drawn at the height the results file gives, a
    line from the ground up to it, the height plotted beside the truth's."""
    import json

    rrd, out = tmp_path / "tri.rrd", tmp_path / "tri.json"
    replay(ROOT / "logs" / "golden" / "scenario2.mcap",
           ReplayOptions(fusion="triangulate", rerun=RerunTarget("save", str(rrd)), out=out,
                         progress=False))
    heights = [s["z_m"] for s in json.loads(out.read_text())["fused"]]
    truths = [s["truth_z_m"] for s in json.loads(out.read_text())["fused"]]
    chunks = [ch for ch in chunk.RrdReader(rrd).stream() if not ch.is_static]

    def values(path: str, column: str) -> list:
        return [v for ch in chunks if ch.entity_path == path
                for v in ch.to_record_batch().column(column).to_pylist()]

    drawn = [p[0][2] for p in values("/field/fused", "Points3D:positions")]
    assert drawn == pytest.approx(heights, abs=1e-6)
    assert [v[0] for v in values("/plots/height/fused", "Scalars:scalars")] == pytest.approx(
        heights, abs=1e-6)
    assert [v[0] for v in values("/plots/height/truth", "Scalars:scalars")] == pytest.approx(
        truths, abs=1e-6)
    lines = values("/field/fused/height", "LineStrips3D:strips")
    assert len(lines) == len(heights)
    assert all(line[0][0][2] == 0.0 and line[0][1][2] == pytest.approx(z, abs=1e-6)
               for line, z in zip(lines, heights, strict=True))


def test_the_fused_label_carries_the_speed_and_the_arrow_has_none(chunks: list) -> None:
    def labels(path: str) -> list[str]:
        out: list[str] = []
        for ch in chunks:
            if ch.entity_path != path or ch.is_static:
                continue
            batch = ch.to_record_batch()
            for name in batch.schema.names:
                if name.endswith(":labels"):
                    for row in batch.column(name).to_pylist():
                        out.extend(row or [])
        return out

    assert labels("/field/track/velocity") == []  # it would sit on the fused label
    fused = labels("/field/fused")
    assert fused and all(re.fullmatch(r"fused \(-?\d+\.\d\d, -?\d+\.\d\d\), \d+\.\d\d m/s", t)
                         for t in fused), fused[:3]


def test_labels_sit_beside_the_ball_and_the_robots_not_on_them(chunks: list) -> None:
    """The camera view's always-shown label is off the ball (the centroid's and the
    radius's show on hovering); the robots' names are below their footprints, whose own
    labels show on hovering."""
    def column(rx: str, name: str) -> dict[tuple[str, int], object]:
        out: dict[tuple[str, int], object] = {}
        for ch in chunks:
            if ch.is_static or not re.fullmatch(rx, ch.entity_path):
                continue
            batch = ch.to_record_batch()
            if name in batch.schema.names:
                frames = batch.column("frame").to_pylist()
                for frame, value in zip(frames, batch.column(name).to_pylist(), strict=True):
                    out[ch.entity_path.split("/")[2 if rx.startswith("/robots") else 3],
                        frame] = value
        return out

    centroids = column(r"/robots/\w+/camera/detection/centroid", "Points2D:positions")
    labels = column(r"/robots/\w+/camera/detection/label", "Points2D:positions")
    assert centroids and set(labels) == set(centroids)
    for key, (at,) in labels.items():  # a rolling ball some metres off: 5+ px across
        assert math.dist(at, centroids[key][0]) > 10.0, key
    texts = column(r"/robots/\w+/camera/detection/label", "Points2D:labels")
    assert all(re.fullmatch(r"\(\d+\.\d, \d+\.\d\) px, r = \d+\.\d px", t[0])
               for t in texts.values())
    for rx, name in ((r"/robots/\w+/camera/detection/centroid", "Points2D:show_labels"),
                     (r"/robots/\w+/camera/detection/radius", "LineStrips2D:show_labels"),
                     (r"/field/robots/\w+", "Boxes3D:show_labels")):
        hidden = column(rx, name)
        assert hidden and all(v == [False] for v in hidden.values()), rx
    boxes = column(r"/field/robots/\w+", "Boxes3D:centers")
    names = column(r"/field/robots/\w+/name", "Points3D:positions")
    assert set(names) == set(boxes)
    for key, (at,) in names.items():  # the name's box clear of the footprint's corners
        (x, y, _), (x0, y0, x1, y1) = boxes[key][0], label_box(at[0], at[1], key[0])
        assert math.hypot(min(max(x, x0), x1) - x, min(max(y, y0), y1) - y) > 0.36, key
    assert {t[0] for t in column(r"/field/robots/\w+/name", "Points3D:labels").values()} == set(
        ROBOTS)


def test_the_recording_ends_with_what_the_replay_learnt(tmp_path: Path) -> None:
    """The default pipeline learns each robot's pose spread from the log (its line fits,
    its residuals): the .rrd's ``/summary/learnt`` says so per robot, in the printed
    summary's words, and names what the results' ``summary.learnt`` holds."""
    rrd, out = tmp_path / "match.rrd", tmp_path / "match.json"
    s = replay(ROOT / "logs" / "golden" / "match.mcap",
               options_for(rerun=RerunTarget("save", str(rrd)), out=out, progress=False))
    learnt = s.beliefs
    assert learnt and set(learnt) == set(ROBOTS)
    docs = [ch for ch in chunk.RrdReader(rrd).stream() if ch.entity_path == "/summary/learnt"]
    assert len(docs) == 1 and docs[0].is_static
    text = docs[0].to_record_batch().column("TextDocument:text").to_pylist()[0][0]
    for robot in ROBOTS:
        assert f"- **{robot}**: {describe_belief(learnt[robot])}" in text
        assert "as its line fits show" in describe_belief(learnt[robot])
