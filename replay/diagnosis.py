"""What a replay that worked must still say: counts that point at a wrong setup, and why.

A replay can run to the end and be wrong in silence: a yellow ball the orange detector never
sees, a camera whose centre is not where the description says (most balls then fall beyond
the calibration), images of another size than the camera described. :class:`Diagnosis` is
a sink that counts, per robot, what it needs to tell; :meth:`Diagnosis.warnings` turns the
counts (and the images and messages the replay skipped) into one line each, with the counts
and the likely cause. The runner prints them on stderr once the outputs are written, also
with ``-q``; with ``--strict`` the first one is the replay's error and nothing is written.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dsp.text import printable
from replay.cameras import Cameras
from replay.records import FrameResult, FrameStatus
from replay.sink import SinkBase

__all__ = ["OUT_OF_RANGE_SHARE", "Diagnosis"]

OUT_OF_RANGE_SHARE = 0.5
"""A robot warns when more than this share of the balls it saw are out of range."""


@dataclass
class _Counts:
    images: int = 0
    """Frames whose image decoded."""
    detections: int = 0
    out_of_range: int = 0
    other_size: int = 0
    size: tuple[int, int] | None = None
    """The first image size unlike the description's (width, height)."""


class Diagnosis(SinkBase):
    """Counts per robot for :meth:`warnings` (constant memory)."""

    def __init__(self, path: Path, robots: tuple[str, ...], cameras: Cameras, *,
                 detector: str = "paper", early: Mapping[str, str] | None = None) -> None:
        self.path = path
        self.detector = detector
        """The detector in use ("paper", "real" or one from outside), for the likely cause."""
        self.early = dict(early or {})
        """Robot -> what the detector's choice found wrong with its first images
        (:mod:`replay.detector_choice`): said unless the whole replay says more."""
        self.robots = robots
        self.cameras = cameras
        self.counts = {r: _Counts() for r in robots}

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
        lines += [w for r, w in self.early.items() if r not in self._blind()]
        lines += self._unseen(log)
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

    def _blind(self) -> list[str]:
        """The robots that saw no ball in any image that decoded."""
        return [r for r, c in self.counts.items() if c.images and not c.detections]

    def _unseen(self, log: str) -> list[str]:
        blind = self._blind()
        if not blind:
            return []
        unlike = {"paper": "is the ball another colour than the detector's orange",
                  "real": "is the ball unlike the ball model's (dsp-calibrate --ball-from "
                  "labelled frames fits one)"}
        cause = (unlike.get(self.detector, f"does the {self.detector} detector not find "
                            "this ball") + ", or the image topic not the ball camera's?")
        if len(blind) == len([c for c in self.counts.values() if c.images]):
            total = sum(self.counts[r].images for r in blind)
            return [f"{log}: no robot saw the ball in any of its images ({total} images: "
                    + ", ".join(f"{r} {self.counts[r].images}" for r in blind)
                    + f"): {cause}"]
        return [f"{log}: {r} saw the ball in none of its {self.counts[r].images} images, "
                "while other robots did: was it hidden from or too far from it all along, or "
                "is its camera covered?" for r in blind]

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
