"""What a replay that worked must still say: counts that point at a wrong setup, and why.

A replay can run to the end and be wrong in silence: a yellow ball the orange detector never
sees, a camera whose centre is not where the description says (most balls then fall beyond
the calibration), images of another size than the camera described, a robot whose balls
never lie where the other robots' do (its pose, its camera, or a look-alike taken for the
ball). :class:`Diagnosis` is
a sink that counts, per robot, what it needs to tell; :meth:`Diagnosis.warnings` turns the
counts (and the images and messages the replay skipped) into one line each, with the counts
and the likely cause. The runner prints them on stderr once the outputs are written, also
with ``-q``; with ``--strict`` the first one is the replay's error and nothing is written.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dsp.text import printable
from replay.cameras import Cameras
from replay.detector_choice import AGREE_M, AGREE_NS
from replay.records import FrameResult, FrameStatus
from replay.sink import SinkBase

__all__ = ["MIN_COMPARED", "OUT_OF_RANGE_SHARE", "Diagnosis"]

OUT_OF_RANGE_SHARE = 0.5
"""A robot warns when more than this share of the balls it saw are out of range."""
MIN_COMPARED = 10
"""A robot warns when none of its balls agrees with another robot's (within
:data:`~replay.detector_choice.AGREE_M` at stamps :data:`~replay.detector_choice.AGREE_NS`
apart) once this many could be compared."""


@dataclass
class _Counts:
    images: int = 0
    """Frames whose image decoded."""
    detections: int = 0
    out_of_range: int = 0
    other_size: int = 0
    size: tuple[int, int] | None = None
    """The first image size unlike the description's (width, height)."""
    compared: int = 0
    """Balls placed on the field with another robot's placed at nearly the same stamp."""
    agreed: int = 0
    """... of which another robot's lies near it."""


class Diagnosis(SinkBase):
    """Counts per robot for :meth:`warnings` (constant memory)."""

    def __init__(self, path: Path, robots: tuple[str, ...], cameras: Cameras, *,
                 detector: str = "paper", ball: Path | None = None,
                 early: Mapping[str, str] | None = None) -> None:
        self.path = path
        self.detector = detector
        """The detector in use ("paper", "real" or one from outside), for the likely cause."""
        self.early = dict(early or {})
        """Robot -> what the detector's choice found wrong with its first images
        (:mod:`replay.detector_choice`): said unless the whole replay says more."""
        self.robots = robots
        self.cameras = cameras
        self.ball = ball
        """The real detector's ball model file, which the warnings name."""
        self.counts = {r: _Counts() for r in robots}
        self._last: dict[str, tuple[int, float, float]] = {}
        """Robot -> the stamp and field position of its latest ball."""

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        c = self.counts[result.robot]
        if image_bgr is not None:
            c.images += 1
            spec = self.cameras.specs[result.robot]
            height, width = image_bgr.shape[:2]
            if (width, height) != (spec.width_px, spec.height_px):
                c.other_size += 1
                c.size = c.size or (int(width), int(height))
        if result.detection is not None:
            c.detections += 1
        if result.status is FrameStatus.OUT_OF_RANGE:
            c.out_of_range += 1
        est = result.estimate
        if est is not None:
            near = [(x, y) for r, (t, x, y) in self._last.items()
                    if r != result.robot and abs(t - result.stamp_ns) <= AGREE_NS]
            if near:
                c.compared += 1
                c.agreed += any(math.hypot(x - est.x_m, y - est.y_m) <= AGREE_M
                                for x, y in near)
            self._last[result.robot] = (result.stamp_ns, est.x_m, est.y_m)

    def warnings(self, *, bad_images: Mapping[str, int] | None = None,
                 bad_messages: Mapping[str, int] | None = None) -> list[str]:
        """One line per thing the user must know, each naming the log, the counts and the
        likely cause."""
        log = printable(str(self.path), limit=200)
        lines: list[str] = []
        if bad_messages:
            lines.append(f"{log}: skipped {sum(bad_messages.values())} bad message(s): "
                         + ", ".join(f"{k} {v}" for k, v in sorted(bad_messages.items())))
        if bad_images:
            lines.append(f"{log}: skipped {sum(bad_images.values())} image(s) that do not "
                         "decode: " + "; ".join(f"{printable(k, limit=300)} ({v})"
                                                 for k, v in sorted(bad_images.items())))
        lines += self._sizes(log)
        apart = self._apart()
        lines += [w for r, w in self.early.items() if r not in self._blind() + apart]
        lines += self._unseen(log)
        lines += [f"{log}: none of the {self.counts[r].compared} balls "
                  f"{printable(r, limit=60)} placed on the field agrees with another robot's "
                  "placed at nearly the same time (within "
                  f"{AGREE_M:g} m, {AGREE_NS / 1e9:g} s): is its pose or its camera "
                  f"description wrong, or does the {self.detector} detector take something "
                  "else for the ball?" for r in apart]
        lines += self._out_of_range(log)
        return lines

    def _where(self, robot: str) -> str:
        source = (self.cameras.sources or {}).get(robot, "")
        return {"metadata": "the log's camera metadata", "paper": "the paper's camera",
                "": "its camera description"}.get(source, source)

    def _sizes(self, log: str) -> list[str]:
        out = []
        for robot, c in self.counts.items():
            if c.size is not None:
                spec = self.cameras.specs[robot]
                out.append(f"{log}: {c.other_size} of {robot}'s {c.images} images are "
                           f"{c.size[0]} x {c.size[1]} px, but {self._where(robot)} describes "
                           f"a {spec.width_px} x {spec.height_px} camera: is it this robot's "
                           "camera? (give --cameras with its size and centre)")
        return out

    def _apart(self) -> list[str]:
        """The robots none of whose balls agrees with another robot's (of enough)."""
        return [r for r, c in self.counts.items() if c.compared >= MIN_COMPARED
                and c.agreed == 0]

    def _blind(self) -> list[str]:
        """The robots that saw no ball in any image that decoded."""
        return [r for r, c in self.counts.items() if c.images and not c.detections]

    def _unseen(self, log: str) -> list[str]:
        blind = self._blind()
        if not blind:
            return []
        cause = f"{self._unlike()}, or the image topic not the ball camera's?"
        if len(blind) == len([c for c in self.counts.values() if c.images]):
            total = sum(self.counts[r].images for r in blind)
            return [f"{log}: no robot saw the ball in any of its images ({total} images: "
                    + ", ".join(f"{r} {self.counts[r].images}" for r in blind)
                    + f"): {cause}"]
        return [f"{log}: {r} saw the ball in none of its {self.counts[r].images} images, "
                "while other robots did: was it hidden from or too far from it all along, or "
                "is its camera covered?" for r in blind]

    def _unlike(self) -> str:
        """Why a detector may see no ball at all, in the words of the detector in use."""
        if self.ball is not None:
            return (f"is the ball unlike the one the ball model {printable(self.ball.name)} "
                    "was fitted to (dsp-calibrate --ball-from fits one to this ball)")
        if self.detector == "paper":
            return "is the ball another colour than the detector's orange"
        return f"does the detector {printable(self.detector, limit=100)} not see this ball"

    def _out_of_range(self, log: str) -> list[str]:
        out = []
        for robot, c in self.counts.items():
            if c.detections and c.out_of_range > OUT_OF_RANGE_SHARE * c.detections:
                spec = self.cameras.specs[robot]
                cu, cv = spec.centre_px
                calibration = self.cameras.calibrations[robot].name
                where = self.cameras.calibration_source or self._where(robot)
                out.append(f"{log}: {c.out_of_range} of the {c.detections} balls {robot} saw "
                           f"are out of range (beyond its calibration or usable radius): is "
                           f"the image centre ({cu:g}, {cv:g}) or the {calibration} "
                           f"calibration from {where} right for this camera?")
        return out
