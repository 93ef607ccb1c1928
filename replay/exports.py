"""Exports for spreadsheets and reports: the estimates as CSV and a figure of the replay.

:class:`CsvSink` (``dsp-replay --out-csv FILE.csv``) writes one row per frame (``kind``
``frame``, a robot's own estimate) and one per fusion step (``kind`` ``fused``), in the
order the replay makes them, with the columns :data:`CSV_COLUMNS` always in that order.
An empty cell is a missing value (no detection, no ground truth, no track). Floats are
rounded as in the results JSON (:data:`replay.results.DECIMALS` places)::

    import pandas as pd
    df = pd.read_csv("run.csv")
    fused = df[df.kind == "fused"]

:class:`PlotSink` (``dsp-replay --plot FILE.png``) keeps the errors and positions (a few
numbers per frame) and draws :func:`replay.figures.replay_figure` when the replay ends.
Both write under a temporary name and appear only after a whole replay.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from dsp.atomic import AtomicFile
from dsp.field import FieldSpec
from replay.results import DECIMALS, FrameResult, StepResult
from replay.sink import SinkBase

__all__ = ["CSV_COLUMNS", "CsvSink", "PlotSink", "ReplayTrace", "csv_rows", "open_exports"]

CSV_COLUMNS = (
    "kind", "index", "robot", "stamp_ns", "t_s", "status",
    "x_m", "y_m", "cov_xx_m2", "cov_xy_m2", "cov_yy_m2",
    "vx_m_s", "vy_m_s",
    "truth_x_m", "truth_y_m", "truth_vx_m_s", "truth_vy_m_s", "error_m",
    "range_m", "bearing_rad", "visibility",
    "cx_px", "cy_px", "r_px", "area_px",
    "robot_x_m", "robot_y_m", "robot_yaw_rad", "robots",
)
"""The CSV's columns, a stable contract: new columns are only ever appended."""


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value)).lower()
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if not math.isfinite(v):
            return ""
        r = round(v, DECIMALS)
        return repr(0.0 if r == 0 else r)
    return str(value)


def _frame_row(f: FrameResult) -> dict[str, Any]:
    det, est, pose = f.detection, f.estimate, f.pose
    return {
        "kind": "frame", "index": f.frame, "robot": f.robot, "stamp_ns": f.stamp_ns,
        "t_s": f.stamp_ns / 1e9, "status": f.status.value,
        "x_m": None if est is None else est.x_m, "y_m": None if est is None else est.y_m,
        "truth_x_m": None if f.truth is None else f.truth[0],
        "truth_y_m": None if f.truth is None else f.truth[1],
        "error_m": f.error_m,
        "range_m": None if est is None else est.range_m,
        "bearing_rad": None if est is None else est.bearing_rad,
        "visibility": None if est is None else est.visibility,
        "cx_px": None if det is None else float(det.cx_px),
        "cy_px": None if det is None else float(det.cy_px),
        "r_px": f.r_px, "area_px": None if det is None else float(det.area_px),
        "robot_x_m": None if pose is None else pose.x_m,
        "robot_y_m": None if pose is None else pose.y_m,
        "robot_yaw_rad": None if pose is None else pose.yaw_rad,
    }


def _step_row(s: StepResult) -> dict[str, Any]:
    fused = s.fused
    velocity = getattr(s, "velocity_m_s", None)
    truth_velocity = getattr(s, "truth_velocity_m_s", None)
    row: dict[str, Any] = {
        "kind": "fused", "index": s.step, "robot": "fused", "stamp_ns": s.stamp_ns,
        "t_s": s.stamp_ns / 1e9, "status": "ok" if fused is not None else "no_estimate",
        "truth_x_m": None if s.truth is None else s.truth[0],
        "truth_y_m": None if s.truth is None else s.truth[1],
        "error_m": s.error_m,
        "vx_m_s": None if velocity is None else velocity[0],
        "vy_m_s": None if velocity is None else velocity[1],
        "truth_vx_m_s": None if truth_velocity is None else truth_velocity[0],
        "truth_vy_m_s": None if truth_velocity is None else truth_velocity[1],
    }
    if fused is not None:
        (cxx, cxy), (_, cyy) = fused.covariance
        row.update(x_m=fused.x_m, y_m=fused.y_m, cov_xx_m2=cxx, cov_xy_m2=cxy, cov_yy_m2=cyy,
                   robots=";".join(sorted(fused.robots)))
    return row


def csv_rows(result: FrameResult | StepResult) -> list[str]:
    """A frame's or step's CSV row: one cell per :data:`CSV_COLUMNS` entry."""
    row = _frame_row(result) if isinstance(result, FrameResult) else _step_row(result)
    return [_cell(row.get(col)) for col in CSV_COLUMNS]


class CsvSink(SinkBase):
    """Sink writing the estimates as CSV to ``path`` (see the module docstring)."""

    def __init__(self, path: Path, *, force: bool = False) -> None:
        self._out = AtomicFile(path, force=force)
        self._file = self._out.tmp.open("w", encoding="utf-8", newline="")
        self._csv = csv.writer(self._file, lineterminator="\n")
        self._csv.writerow(CSV_COLUMNS)

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        self._csv.writerow(csv_rows(result))

    def step(self, result: StepResult) -> None:
        self._csv.writerow(csv_rows(result))

    def close(self, ok: bool) -> None:
        try:
            self._file.close()
            if ok:
                self._out.commit()
        finally:
            self._out.discard()


class ReplayTrace(SinkBase):
    """Sink keeping what the replay figure shows: per frame (t, robot, error, estimate,
    pose), per step (t, fused position, truth, error). A few numbers per frame."""

    def __init__(self, robots: tuple[str, ...], field: FieldSpec, title: str) -> None:
        self.robots = robots
        self.field = field
        self.title = title
        self.frames: dict[str, list[tuple[float, float, float, float]]] = {r: [] for r in robots}
        """robot -> [(t_s, error_m, x_m, y_m)], NaN where there is none."""
        self.poses: dict[str, list[tuple[float, float, float]]] = {r: [] for r in robots}
        self.fused: list[tuple[float, float, float, float]] = []
        """[(t_s, error_m, x_m, y_m)], NaN where there is no estimate."""
        self.truth: list[tuple[float, float]] = []

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        est, nan = result.estimate, math.nan
        err = nan if result.error_m is None else result.error_m
        xy = (nan, nan) if est is None else (est.x_m, est.y_m)
        self.frames.setdefault(result.robot, []).append((result.stamp_ns / 1e9, err, *xy))
        if result.pose is not None:
            self.poses.setdefault(result.robot, []).append(
                (result.pose.x_m, result.pose.y_m, result.pose.yaw_rad))

    def step(self, result: StepResult) -> None:
        fused, nan = result.fused, math.nan
        err = nan if result.error_m is None else result.error_m
        xy = (nan, nan) if fused is None else (fused.x_m, fused.y_m)
        self.fused.append((result.stamp_ns / 1e9, err, *xy))
        if result.truth is not None:
            self.truth.append(result.truth)


class PlotSink(ReplayTrace):
    """Sink drawing the replay figure to ``path`` (.png or .svg) when the replay ends."""

    def __init__(self, path: Path, *, robots: tuple[str, ...], field: FieldSpec, title: str,
                 force: bool = False) -> None:
        super().__init__(robots, field, title)
        self._out = AtomicFile(path, force=force)
        self._fmt = Path(path).suffix.lower().lstrip(".") or "png"

    def close(self, ok: bool) -> None:
        try:
            if ok:
                from dsp.plotting import save
                from replay.figures import replay_figure

                save(replay_figure(self), self._out.tmp, fmt=self._fmt)
                self._out.commit()
        finally:
            self._out.discard()


def open_exports(stack: Any, info: Any, options: Any) -> list[SinkBase]:
    """The CSV and figure sinks ``options`` (:class:`~replay.options.ReplayOptions`) ask for,
    entered in ``stack``; ``info`` is the log's :class:`~replay.log.reader.LogInfo`."""
    from dsp.field import DEFAULT_FIELD, FIELDS

    sinks: list[SinkBase] = []
    if options.out_csv is not None:
        sinks.append(stack.enter_context(CsvSink(Path(options.out_csv), force=options.force)))
    if options.plot is not None:
        field = info.scenario.field if info.scenario is not None else FIELDS[DEFAULT_FIELD]
        scenario = info.scenario.name if info.scenario is not None else "log"
        title = (f"{scenario}: {options.method} estimator, {options.fusion_method} fusion")
        sinks.append(stack.enter_context(PlotSink(
            Path(options.plot), robots=tuple(info.robots), field=field, title=title,
            force=options.force)))
    return sinks
