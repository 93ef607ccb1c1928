"""Omni frames per second per camera model and renderer, beside the floor: one plain
1080 x 1080 pybullet render; and what the venue's trouble and lobs cost per frame.

    python benchmarks/bench_record.py [--runs 5] [--face-px 1024] [--renderers egl,tiny]
    python benchmarks/bench_record.py --venue [--camera ideal] [--rounds 3]

Each figure is the median over ``--runs`` timed runs (after one warm-up) of rendering one
robot's omni image in the scenario-1 world (three robots, the ball at the centre), with and
without PNG encoding (what the recorder writes per robot and frame). The floor and the
models' renders are timed in turn within each run, so the machine's load falls on all
alike; the ratio to the floor is the figure to compare across machines.
"""

from __future__ import annotations

import argparse
import statistics
import time

import cv2
import numpy as np

from estimator.camera import CAMERA_MODELS, make_camera
from recorder.ball import ball_look
from recorder.flight import Flight
from recorder.omni import DEFAULT_FACE_PX, OmniRenderer, _look_at, _perspective
from recorder.scenarios import make_scenario
from recorder.world import World, field_spec


def _timed(fn) -> float:  # type: ignore[no-untyped-def]
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def bench(renderer: str, face_px: int, runs: int) -> list[str]:
    sc = make_scenario("scenario1")
    rows = []
    with World(field_spec(sc.field), renderer=renderer) as world:
        if world.renderer != renderer:
            return [f"{renderer:5s} not available (got {world.renderer})"]
        for tr in sc.robots:
            world.add_robot(tr.name)
            world.set_robot_pose(tr.name, *tr.pose_at(0.0))
        world.set_ball(*sc.ball_xy_m)
        r2 = sc.robots[1]
        x, y, yaw = r2.pose_at(0.0)
        eye = np.array([x, y, 0.85])
        view = _look_at(eye, np.array([1.0, 0.0, -0.3]), np.array([0.0, 0.0, 1.0]))
        proj = _perspective(90.0, 0.02, 80.0)
        omnis, builds = {}, {}
        for name in CAMERA_MODELS:
            t0 = time.perf_counter()
            omnis[name] = OmniRenderer(make_camera(name), face_px=face_px,
                                       renderer=world.renderer)
            builds[name] = time.perf_counter() - t0
        jobs = {"floor": lambda: world.render(1080, 1080, view, proj)}
        for name, omni in omnis.items():
            jobs[name] = lambda omni=omni: omni.render(world, r2.name, x, y, yaw)
        times: dict[str, list[float]] = {k: [] for k in jobs}
        for job in jobs.values():  # warm up
            job()
        for _ in range(runs):  # interleaved, so the machine's load falls on all alike
            for key, job in jobs.items():
                times[key].append(_timed(job))
        floor = statistics.median(times["floor"])
        rows.append(f"{renderer:5s} floor: one plain 1080x1080 render {floor * 1e3:7.1f} ms")
        for name, omni in omnis.items():
            render = statistics.median(times[name])
            img = omni.render(world, r2.name, x, y, yaw)
            png = statistics.median(_timed(lambda img=img: cv2.imencode(
                ".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 3])) for _ in range(runs))
            faces = "+".join(f"{f}{w}x{h}" for f, w, h in omni.pieces)
            rows.append(
                f"{renderer:5s} {name:8s} omni {render * 1e3:7.1f} ms = {render / floor:4.2f}x "
                f"the floor ({omni.rendered_px / 1e6:.2f} Mpx rendered: {faces}); +png "
                f"{png * 1e3:5.1f} ms -> {1 / (render + png):5.2f} fps; tables built once in "
                f"{builds[name]:.2f} s"
            )
    return rows


VENUES: dict[str, dict[str, int | str]] = {
    "as before": {},
    "panels": {"pattern": "panels"},
    "light pools 3": {"light_pools": 3},
    "people 6, covers 2": {"people": 6, "covers": 2},
    "all of them": {"pattern": "panels", "light_pools": 3, "people": 6, "covers": 2},
}
"""The --venue variants, each in a world of its own (with EGL two worlds alive at once
disturb each other's images once one has a textured ball)."""


def _venue_world(renderer: str, venue: dict[str, int | str]) -> tuple[World, list[str]]:
    """The match world of seed 0 dressed as ``venue``; the names of its robots."""
    sc = make_scenario("match", 0, people=int(venue.get("people", 0)),
                       covers=int(venue.get("covers", 0)),
                       light_pools=int(venue.get("light_pools", 0)))
    lights = sc.scenery.light_pools if sc.scenery is not None else ()
    world = World(field_spec(sc.field), renderer=renderer, light=lights,
                  ball=ball_look("yellow", str(venue.get("pattern", "plain"))))
    for tr in sc.robots:
        world.add_robot(tr.name)
        world.set_robot_pose(tr.name, *tr.pose_at(0.0))
    if sc.scenery is not None:
        for person in sc.scenery.people:
            world.add_person(person)
        for name in sc.scenery.covers:
            world.add_cover(name)
    world.set_ball(*sc.ball_xy_m, 2.0, 1.0)
    return world, [tr.name for tr in sc.robots]


def _time_venue(world: World, robot: str, camera: str, face_px: int, runs: int
                ) -> tuple[float, float, int]:
    """Median seconds of a plain 1080 x 1080 render and of one omni image (relit first, as
    the frame loop does), timed in turn; the omni image's PNG size [bytes]."""
    omni = OmniRenderer(make_camera(camera), face_px=face_px, renderer=world.renderer)
    view = _look_at(np.array([0.0, 0.0, 0.85]), np.array([1.0, 0.0, -0.3]),
                    np.array([0.0, 0.0, 1.0]))
    proj = _perspective(90.0, 0.02, 80.0)

    def frame() -> None:
        world.relight()
        omni.render(world, robot, 0.0, 0.0, 0.0)

    jobs = {"floor": lambda: world.render(1080, 1080, view, proj), "omni": frame}
    times: dict[str, list[float]] = {k: [] for k in jobs}
    for job in jobs.values():
        job()
    for _ in range(runs):
        for key, job in jobs.items():
            times[key].append(_timed(job))
    world.relight()
    img = omni.render(world, robot, 0.0, 0.0, 0.0)
    png = len(cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 3])[1])
    return statistics.median(times["floor"]), statistics.median(times["omni"]), png


def _time_flight(renderer: str, runs: int) -> tuple[float, float]:
    """Median seconds of 12 physics steps (a match frame at 20 Hz) without and with a
    lob's flight bookkeeping (the damping of air or ground after every step)."""
    with World(field_spec("18x12"), renderer=renderer) as world:
        flight = Flight(world)
        world.set_ball(0.0, 0.0)
        plain = [_timed(lambda: world.step(12)) for _ in range(runs * 20)]

        def flown() -> None:
            for _ in range(12):
                world.step()
                flight.step()
        lob = [_timed(flown) for _ in range(runs * 20)]
    return statistics.median(plain), statistics.median(lob)


def bench_venue(renderer: str, camera: str, face_px: int, runs: int, rounds: int = 3
                ) -> list[str]:
    """Per variant of VENUES, one robot's omni image over a plain render in the same world;
    the variants are visited in turn ``rounds`` times (a world each visit), so the
    machine's load falls on all alike; then the physics of a frame with and without lobs."""
    ratios: dict[str, list[float]] = {label: [] for label in VENUES}
    renders: dict[str, list[float]] = {label: [] for label in VENUES}
    pngs: dict[str, int] = {}
    for _ in range(rounds):
        for label, venue in VENUES.items():
            world, robots = _venue_world(renderer, venue)
            with world:
                if world.renderer != renderer:
                    return [f"{renderer:5s} not available (got {world.renderer})"]
                floor, render, pngs[label] = _time_venue(world, robots[1], camera, face_px,
                                                         runs)
            ratios[label].append(render / floor)
            renders[label].append(render)
    base = statistics.median(ratios["as before"])
    rows = []
    for label in VENUES:
        ratio = statistics.median(ratios[label])
        rows.append(f"{renderer:5s} {camera:8s} {label:20s} omni "
                    f"{statistics.median(renders[label]) * 1e3:7.1f} ms = {ratio:4.2f}x the "
                    f"floor, {ratio / base:4.2f}x as before (median of {rounds} rounds); "
                    f"PNG {pngs[label] / 1e3:.0f} kB")
    plain, lob = _time_flight(renderer, runs)
    rows.append(f"{renderer:5s} physics of one 20 Hz frame (12 steps): {plain * 1e3:.3f} ms, "
                f"with the flight's bookkeeping {lob * 1e3:.3f} ms")
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    p.add_argument("--runs", type=int, default=7)
    p.add_argument("--face-px", type=int, default=DEFAULT_FACE_PX)
    p.add_argument("--renderers", default="egl,tiny")
    p.add_argument("--venue", action="store_true",
                   help="the cost of the ball's pattern, light pools, people and covers, lobs")
    p.add_argument("--camera", default="ideal", help="the camera of --venue")
    p.add_argument("--rounds", type=int, default=3, help="visits of each --venue variant")
    args = p.parse_args()
    print(f"face {args.face_px} px, median of {args.runs} runs, cv2 threads "
          f"{cv2.getNumThreads()}")
    for r in args.renderers.split(","):
        rows = (bench_venue(r.strip(), args.camera, args.face_px, args.runs, args.rounds)
                if args.venue
                else bench(r.strip(), args.face_px, args.runs))
        for row in rows:
            print(row)


if __name__ == "__main__":
    main()
