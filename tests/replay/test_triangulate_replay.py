"""Replay with the 3-D fusion: heights in the results and the CSV, the truth's height read,
ground balls placed as well as the ground-plane fusions place them; the lobs suite's score."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from estimator.constants import BALL_RADIUS_M
from replay.evaluate.lobs import FLIGHT_ABOVE_M, score_lobs
from replay.log.messages import TruthMessage
from replay.options import ReplayOptions
from replay.runner import replay
from replay.sync import History, interpolate_truth_z

GOLDEN = Path(__file__).resolve().parents[2] / "logs" / "golden"


@pytest.fixture(scope="module")
def scenario2(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, list[dict[str, str]]]:
    d = tmp_path_factory.mktemp("tri")
    replay(GOLDEN / "scenario2.mcap", ReplayOptions(
        fusion="triangulate", out=d / "r.json", out_csv=d / "r.csv", progress=False))
    with (d / "r.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    return json.loads((d / "r.json").read_text()), rows


def test_a_ball_on_the_ground_is_triangulated_on_the_ground(scenario2: tuple) -> None:
    doc, _ = scenario2
    assert doc["fused"]
    for s in doc["fused"]:
        assert s["triangulated"] and len(s["fused_robots"]) == 3
        assert abs(s["truth_z_m"] - BALL_RADIUS_M) < 1e-3  # the truth's height was read
        assert abs(s["z_error_m"]) < 0.02 and s["error_m"] < 0.015
        assert s["error_3d_m"] == pytest.approx(math.hypot(s["error_m"], s["z_error_m"]),
                                                abs=2e-6)
        cov = s["covariance_3d"]
        assert [cov[0][0], cov[0][1], cov[1][1]] == pytest.approx(
            [s["covariance"][0][0], s["covariance"][0][1], s["covariance"][1][1]])
        assert cov[2][2] > 0


def test_the_csv_carries_the_height(scenario2: tuple) -> None:
    doc, rows = scenario2
    fused = [r for r in rows if r["kind"] == "fused"]
    assert len(fused) == len(doc["fused"])
    for row, ref in zip(fused, doc["fused"], strict=True):
        assert float(row["z_m"]) == ref["z_m"]
        assert float(row["cov_zz_m2"]) == ref["covariance_3d"][2][2]
        assert float(row["truth_z_m"]) == ref["truth_z_m"]
    frames = [r for r in rows if r["kind"] == "frame"]
    assert all(r["z_m"] == "" for r in frames)


def test_a_ground_plane_fusion_writes_no_height(tmp_path: Path) -> None:
    replay(GOLDEN / "scenario2.mcap", ReplayOptions(fusion="robust", out=tmp_path / "r.json",
                                                    progress=False))
    doc = json.loads((tmp_path / "r.json").read_text())
    assert not any(k in s for s in doc["fused"] for k in ("z_m", "covariance_3d"))


def test_the_truth_height_is_interpolated() -> None:
    h: History[TruthMessage] = History(10**9)
    h.add(TruthMessage(0, 0.0, 0.0, z_m=0.11))
    h.add(TruthMessage(100, 1.0, 0.0, z_m=1.11))
    assert interpolate_truth_z(h, 25, 1000) == pytest.approx(0.36)
    assert interpolate_truth_z(h, 5000, 1000) is None
    old: History[TruthMessage] = History(10**9)
    old.add(TruthMessage(0, 0.0, 0.0))
    assert interpolate_truth_z(old, 0, 10) is None


def _step(t: int, z_true: float, z: float, err: float, tri: bool) -> dict:
    return {"stamp_ns": t, "truth": {"x_m": 0.0, "y_m": 0.0}, "truth_z_m": z_true,
            "z_m": z, "triangulated": tri, "error_m": err, "z_error_m": z - z_true,
            "error_3d_m": math.hypot(err, z - z_true)}


def test_the_lobs_score_splits_flight_and_ground() -> None:
    tri = [_step(0, 1.5, 1.53, 0.04, True),       # in flight, two robots: counted
           _step(1, 2.0, BALL_RADIUS_M, 0.5, False),  # in flight, one robot: only seen
           _step(2, BALL_RADIUS_M, 0.115, 0.01, True),  # on the ground
           _step(3, 0.2, 0.2, 0.0, True)]        # bouncing low: neither
    plane = [{"stamp_ns": 0, "error_m": 3.0}, {"stamp_ns": 2, "error_m": 0.01}]
    frames = [{"stamp_ns": 0, "robot": "r1", "error_m": 4.0},
              {"stamp_ns": 2, "robot": "r1", "error_m": 0.02}]
    s = score_lobs(tri, plane, frames)
    assert s.flight_steps == 2 and len(s.flight_3d) == 1
    assert s.flight_3d[0] == pytest.approx(0.05) and s.flight_z[0] == pytest.approx(0.03)
    assert s.plane_flight_3d[0] == pytest.approx(math.hypot(3.0, 1.5 - BALL_RADIUS_M))
    assert s.ground_3d == [pytest.approx(math.hypot(0.01, 0.005))]
    assert s.plane_ground_3d == [pytest.approx(0.01)]
    assert s.robots_flight == {"r1": [pytest.approx(math.hypot(4.0, 1.5 - BALL_RADIUS_M))]}
    assert FLIGHT_ABOVE_M < 1.5


def test_the_tracker_score_takes_the_landing_predicted_03_s_ahead() -> None:
    """The ``ballistic`` steps' in-flight errors are counted where rays crossed, and a
    landing is scored by the last prediction made 0.3 s or more before it."""
    from estimator.constants import NS_PER_S
    from replay.evaluate.lobs_track import score_track

    def step(t: float, z_true: float, err: float, tri: bool, land: tuple | None) -> dict:
        return {"stamp_ns": round(t * NS_PER_S), "z_m": z_true, "truth_z_m": z_true,
                "triangulated": tri, "error_3d_m": err,
                "landing": None if land is None else {"x_m": land[0], "y_m": land[1]}}

    steps = [step(0.0, 1.0, 0.01, True, (5.0, 0.1)),
             step(0.1, 1.2, 0.5, False, (5.0, 0.2)),     # one robot: not scored in flight
             step(0.2, 1.0, 0.02, True, (5.0, 0.3)),     # the last 0.3 s before landing
             step(0.3, 0.8, 0.03, True, (9.0, 9.0)),     # too late to count
             step(0.6, BALL_RADIUS_M, 0.0, True, None)]  # landed
    s = score_track(steps, [(round(0.55 * NS_PER_S), 5.0, 0.0),
                            (round(0.25 * NS_PER_S), 0.0, 0.0)], FLIGHT_ABOVE_M)
    assert s.flight_3d == [0.01, 0.02, 0.03] and s.landings == 2
    assert s.landing_errors == [pytest.approx(0.3)]  # the second: nothing 0.3 s before it
    assert s.landing_leads_s == [pytest.approx(0.35)]
