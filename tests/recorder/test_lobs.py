"""Lobs: drawn within the MSL's range, flown by pybullet with air drag, bounced with a
football's restitution, rolled after; the truth in 3-D; kicks wait while the ball flies."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from dsp import contract as c
from dsp.metadata import ScenarioMetadata
from recorder.flight import AIR_DAMPING, LOB_FLIGHT, Flight
from recorder.match import (
    LOB_APEX_M,
    LOB_ELEVATION_DEG,
    LOB_SPEED_MPS,
    LobKick,
    draw_lob,
)
from recorder.record import RecordOptions, record
from recorder.scenarios import make_scenario
from recorder.world import BALL_RADIUS_M, PHYSICS_HZ, World, field_spec

G = 9.81
DT = 1.0 / PHYSICS_HZ


def _peaks(z: np.ndarray) -> list[int]:
    """Indices of the local maxima of a flight (above 2 cm over resting height)."""
    return [i for i in range(1, len(z) - 1)
            if z[i] > z[i - 1] and z[i] >= z[i + 1] and z[i] > BALL_RADIUS_M + 0.02]


def _fly(world: World, flight: Flight, kick: LobKick, seconds: float) -> np.ndarray:
    """Launch ``kick`` from (-6, 0) towards +x; rows of (x, y, z, vx, vy, vz) per step."""
    world.set_ball(-6.0, 0.0)
    world.step()
    flight.step()
    flight.launch(kick, 1.0, 0.0)
    rows = []
    for _ in range(round(seconds * PHYSICS_HZ)):
        world.step()
        flight.step()
        rows.append((*world.ball_position(), *world.ball_velocity()))
    return np.array(rows)


def test_lobs_are_drawn_within_the_leagues_range() -> None:
    rng = np.random.default_rng(0)
    for _ in range(500):
        elevation, speed = draw_lob(rng)
        assert LOB_ELEVATION_DEG[0] <= elevation <= LOB_ELEVATION_DEG[1]
        assert LOB_SPEED_MPS[0] <= speed <= LOB_SPEED_MPS[1]
        vz = speed * math.sin(math.radians(elevation))
        assert LOB_APEX_M[0] <= BALL_RADIUS_M + vz * vz / (2 * G) <= LOB_APEX_M[1] + 1e-3


@pytest.fixture(scope="module")
def flights() -> list[tuple[LobKick, np.ndarray]]:
    """Five drawn lobs flown on an empty field for 4 s each."""
    rng = np.random.default_rng(7)
    out = []
    with World(field_spec("22x14"), renderer="tiny") as world:
        flight = Flight(world)
        for _ in range(5):
            elevation, speed = draw_lob(rng)
            kick = LobKick(0.0, speed, None, (10.0, 0.0), elevation_deg=elevation)
            out.append((kick, _fly(world, flight, kick, 4.0)))
    return out


def test_a_lob_flies_1_to_3_m_high_lands_bounces_lower_and_rolls(
        flights: list[tuple[LobKick, np.ndarray]]) -> None:
    for kick, rows in flights:
        z = rows[:, 2]
        peaks = _peaks(z)
        assert len(peaks) >= 2, kick
        heights = z[peaks]
        assert 1.0 <= heights[0] <= 3.0, (kick, heights)
        assert np.all(np.diff(heights) < 0), heights  # every bounce lower
        # the speed kept at a bounce (from the heights: v = sqrt(2 g h)): about 0.6
        kept = np.sqrt((heights[1:3] - BALL_RADIUS_M) / (heights[:2] - BALL_RADIUS_M))
        assert np.all((0.5 < kept) & (kept < 0.7)), kept
        # between the peaks it touches the ground; at the end it rolls on it
        assert z[peaks[0]:peaks[1]].min() < BALL_RADIUS_M + 0.005
        assert abs(z[-1] - BALL_RADIUS_M) < 0.005 and abs(rows[-1, 5]) < 0.05
        assert 0.3 < math.hypot(rows[-1, 3], rows[-1, 4]) < math.hypot(rows[0, 3], rows[0, 4])
        assert abs(rows[:, 1]).max() < 1e-6  # straight along the kick


def test_in_the_air_only_gravity_and_the_stated_drag_act(
        flights: list[tuple[LobKick, np.ndarray]]) -> None:
    """dv/dt = -g z - d (1 + |v|) v with d = AIR_DAMPING, step by step, while the ball is
    clear of the ground (pybullet applies the drag to the velocity after gravity)."""
    for _, rows in flights:
        first = _peaks(rows[:, 2])[0]
        v = rows[5:2 * first - 5, 3:]  # the first flight, clear of both contacts
        for v0, v1 in itertools.pairwise(v):
            w = v0 + np.array([0.0, 0.0, -G * DT])
            predicted = w * (1.0 - DT * AIR_DAMPING * (1.0 + float(np.linalg.norm(w))))
            assert np.allclose(v1, predicted, atol=2e-4), (v0, v1, predicted)


def test_drag_takes_a_few_percent_off_the_drag_free_flight(
        flights: list[tuple[LobKick, np.ndarray]]) -> None:
    for kick, rows in flights:
        vz = kick.speed_mps * math.sin(math.radians(kick.elevation_deg))
        apex = BALL_RADIUS_M + vz * vz / (2 * G)
        assert 0.92 * apex < rows[:, 2].max() < 0.99 * apex


def test_lob_fraction_turns_some_kicks_into_lobs_and_nothing_else() -> None:
    plain = make_scenario("match", 5)
    assert make_scenario("match", 5, lob_fraction=0.0) == plain
    assert plain.flight is None and "flight" not in plain.params()
    assert plain.play is not None and not any(isinstance(k, LobKick) for k in plain.play.kicks)
    half = make_scenario("match", 5, lob_fraction=0.5)
    assert half.play is not None and half.flight == LOB_FLIGHT
    assert half.robots == plain.robots and half.ball_xy_m == plain.ball_xy_m
    for a, b in zip(plain.play.kicks, half.play.kicks, strict=True):
        assert (a.t_s, a.target_robot, a.target_xy_m) == (b.t_s, b.target_robot, b.target_xy_m)
        if not isinstance(b, LobKick):
            assert a == b
    share = np.mean([isinstance(k, LobKick) for k in half.play.kicks])
    assert 0.3 < share < 0.7
    lobs = make_scenario("lobs", 5)
    assert lobs.play is not None and all(isinstance(k, LobKick) for k in lobs.play.kicks)
    gaps = np.diff([k.t_s for k in lobs.play.kicks])
    assert gaps.min() >= 2.4 - 1e-3 and gaps.max() <= 3.6 + 1e-3
    assert make_scenario("lobs", 5) == lobs and make_scenario("lobs", 6) != lobs


def _truth(path: Path) -> tuple[np.ndarray, dict[str, Any]]:
    """(t, x, y, z, vx, vy, vz) rows of the ball's true odometry; the scenario's params."""
    rows = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _s, _ch, message, odo in reader.iter_decoded_messages(
                topics=[c.GT_BALL_ODOMETRY_TOPIC]):
            p, v = odo.pose.pose.position, odo.twist.twist.linear
            rows.append((message.log_time / 1e9, p.x, p.y, p.z, v.x, v.y, v.z))
        f.seek(0)
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    return np.array(rows), ScenarioMetadata.from_metadata(meta[c.SCENARIO_METADATA]).params()


@pytest.fixture(scope="module")
def lobs_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """6 s of the lobs scenario (seed 2): truth at 240 Hz, one image a second per robot."""
    path = tmp_path_factory.mktemp("lobs") / "lobs.mcap"
    record(path, RecordOptions(scenario="lobs", seed=2, rate_hz=1.0, frames=6, face_px=256,
                               renderer="tiny"))
    return path


def test_the_lobs_log_holds_the_flight_in_3d(lobs_log: Path) -> None:
    rows, params = _truth(lobs_log)
    t, z, vz = rows[:, 0], rows[:, 3], rows[:, 6]
    assert np.allclose(np.diff(t), 1 / 240, atol=1e-8)
    assert 1.0 <= z.max() <= 3.0
    peaks = _peaks(z)
    assert any(z[a] > 1.0 and z[b] < z[a] for a, b in itertools.pairwise(peaks))
    # the truth's vz is the truth's z changing (centred differences, away from contacts)
    dz = (z[2:] - z[:-2]) / (t[2:] - t[:-2])
    air = (z[1:-1] > BALL_RADIUS_M + 0.05) & (np.abs(np.diff(vz, 2)) < 0.01)
    assert np.allclose(dz[air], vz[1:-1][air], atol=0.03)
    assert params["recording"]["lob_fraction"] == 1.0 and params["recording"]["ball_odometry"]
    assert params["flight"]["restitution"] == LOB_FLIGHT.restitution
    assert all("elevation_deg" in k for k in params["play"]["kicks"])
    _struck_from_the_ground(rows, params)


def _struck_from_the_ground(rows: np.ndarray, params: dict[str, Any]) -> list[float]:
    """Every kick due in the log was struck from the ground, at or after its time; the
    delays [s]."""
    t, z, vz = rows[:, 0], rows[:, 3], rows[:, 6]
    delays = []
    for kick in (k for k in params["play"]["kicks"] if k["t_s"] < t[-1] - 0.5):
        after = t >= kick["t_s"] - 1e-9
        # struck: vz jumps from nearly none to a lob's (a bounce jumps from below -1 m/s
        # to at most 0.6 of that)
        launched = np.nonzero(after[1:] & (vz[:-1] > -1.0) & (vz[1:] > 2.0))[0]
        assert len(launched), kick
        k = launched[0]
        assert z[k] < BALL_RADIUS_M + LOB_FLIGHT.airborne_above_m + 1e-3
        delays.append(float(t[k + 1] - kick["t_s"]))
    return delays


def test_a_kick_waits_while_the_ball_flies(tmp_path: Path) -> None:
    """A match whose kicks come 1.2-2.6 s apart, all lobs (flights and bounces of up to
    2 s): a kick that falls due in the air is struck once the ball is down."""
    path = tmp_path / "match.mcap"
    record(path, RecordOptions(scenario="match", seed=1, lob_fraction=1.0, rate_hz=1.0,
                               frames=8, face_px=256, renderer="tiny"))
    rows, params = _truth(path)
    assert params["recording"]["lob_fraction"] == 1.0
    delays = _struck_from_the_ground(rows, params)
    assert len(delays) >= 3 and max(delays) > 0.1 and min(delays) < 0.01, delays
