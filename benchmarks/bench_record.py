"""Omni frames per second per camera model and renderer, beside the floor: one plain
1080 x 1080 pybullet render.

    python benchmarks/bench_record.py [--runs 5] [--face-px 1024] [--renderers egl,tiny]

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


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    p.add_argument("--runs", type=int, default=7)
    p.add_argument("--face-px", type=int, default=DEFAULT_FACE_PX)
    p.add_argument("--renderers", default="egl,tiny")
    args = p.parse_args()
    print(f"face {args.face_px} px, median of {args.runs} runs, cv2 threads "
          f"{cv2.getNumThreads()}")
    for r in args.renderers.split(","):
        for row in bench(r.strip(), args.face_px, args.runs):
            print(row)


if __name__ == "__main__":
    main()
