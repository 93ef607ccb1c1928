"""The estimates as CSV, for spreadsheets: ``dsp-replay --out-csv FILE.csv``.

:class:`CsvSink` writes one row per frame (``kind``
``frame``, a robot's own estimate) and one per fusion step (``kind`` ``fused``), in the
order the replay makes them, with the columns :data:`CSV_COLUMNS` always in that order.
An empty cell is a missing value (no detection, no ground truth, no track). Floats are
rounded as in the results JSON (:data:`replay.sinks.results_json.DECIMALS` places)::

    import pandas as pd
    df = pd.read_csv("run.csv")
    fused = df[df.kind == "fused"]

It writes under a temporary name, and the file appears only after a whole replay.
"""

from __future__ import annotations

import contextlib
import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from dsp.atomic import AtomicFile
from dsp.textfile import TEXT_ERRORS
from estimator.constants import NS_PER_S
from replay.records import FrameResult, Localisation, StepResult
from replay.sink import SinkBase
from replay.sinks.results_json import DECIMALS

__all__ = ["CSV_COLUMNS", "LOCALISATION_COLUMNS", "CsvSink", "csv_rows"]

CSV_COLUMNS = (
    "kind", "index", "robot", "stamp_ns", "t_s", "status",
    "x_m", "y_m", "cov_xx_m2", "cov_xy_m2", "cov_yy_m2",
    "vx_m_s", "vy_m_s",
    "truth_x_m", "truth_y_m", "truth_vx_m_s", "truth_vy_m_s", "error_m",
    "range_m", "bearing_rad", "visibility",
    "cx_px", "cy_px", "r_px", "area_px",
    "robot_x_m", "robot_y_m", "robot_yaw_rad", "robots",
    "z_m", "cov_zz_m2", "truth_z_m", "error_3d_m",
    "vz_m_s", "landing_t_s", "landing_x_m", "landing_y_m",
)
"""The CSV's columns, a stable contract: new columns are only ever appended."""
LOCALISATION_COLUMNS = (
    "pose_source", "pose_status", "corrected_x_m", "corrected_y_m", "corrected_yaw_rad",
    "corrected_cov_xx_m2", "corrected_cov_xy_m2", "corrected_cov_yy_m2",
    "corrected_cov_yawyaw_rad2", "line_points", "line_inliers",
)
"""With ``--localise lines``, after :data:`CSV_COLUMNS`: each frame's pose corrected from
the field lines (the believed one stays ``robot_x_m``...), its covariance and where it came
from (:class:`replay.records.Localisation`); empty on fused rows. Without it the file has
only :data:`CSV_COLUMNS`."""


def _cell(value: object) -> str:
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


def _frame_row(f: FrameResult) -> dict[str, object]:
    det, est, pose = f.detection, f.estimate, f.pose
    return {
        "kind": "frame", "index": f.frame, "robot": f.robot, "stamp_ns": f.stamp_ns,
        "t_s": f.stamp_ns / NS_PER_S, "status": f.status.value,
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
        **_localisation_cells(f.localisation),
    }


def _localisation_cells(loc: Localisation | None) -> dict[str, object]:
    if loc is None:
        return {}
    (cxx, cxy, _), (_, cyy, _), (_, _, caa) = loc.covariance
    return {"pose_source": loc.source, "pose_status": loc.status,
            "corrected_x_m": loc.pose.x_m, "corrected_y_m": loc.pose.y_m,
            "corrected_yaw_rad": loc.pose.yaw_rad, "corrected_cov_xx_m2": cxx,
            "corrected_cov_xy_m2": cxy, "corrected_cov_yy_m2": cyy,
            "corrected_cov_yawyaw_rad2": caa, "line_points": loc.points,
            "line_inliers": loc.inliers}


def _step_row(s: StepResult) -> dict[str, object]:
    fused = s.fused
    velocity, truth_velocity = s.velocity_m_s, s.truth_velocity_m_s
    row: dict[str, object] = {
        "kind": "fused", "index": s.step, "robot": "fused", "stamp_ns": s.stamp_ns,
        "t_s": s.stamp_ns / NS_PER_S, "status": "ok" if fused is not None else "no_estimate",
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
        if fused.z_m is not None:  # a 3-D fusion
            row.update(z_m=fused.z_m, truth_z_m=s.truth_z_m, error_3d_m=s.error_3d_m,
                       cov_zz_m2=None if fused.covariance_3d is None
                       else fused.covariance_3d[2][2])
    if s.vz_m_s is not None:  # the ballistic tracker
        row["vz_m_s"] = s.vz_m_s
    if s.landing is not None:
        row.update(landing_t_s=s.landing.stamp_ns / NS_PER_S, landing_x_m=s.landing.x_m,
                   landing_y_m=s.landing.y_m)
    return row


def csv_rows(result: FrameResult | StepResult,
             columns: tuple[str, ...] = CSV_COLUMNS) -> list[str]:
    """A frame's or step's CSV row: one cell per entry of ``columns``."""
    row = _frame_row(result) if isinstance(result, FrameResult) else _step_row(result)
    return [_cell(row.get(col)) for col in columns]


class CsvSink(SinkBase):
    """Sink writing the estimates as CSV to ``path`` (see the module docstring);
    ``localised``: with the :data:`LOCALISATION_COLUMNS` too."""

    def __init__(self, path: Path, *, force: bool = False, localised: bool = False) -> None:
        self.columns = CSV_COLUMNS + (LOCALISATION_COLUMNS if localised else ())
        self._out = AtomicFile(path, force=force)
        self._file = io.TextIOWrapper(self._out.stream(), encoding="utf-8", errors=TEXT_ERRORS,
                                      newline="")
        self._csv = csv.writer(self._file, lineterminator="\n")
        self._row(self.columns)

    def _row(self, row: Sequence[str]) -> None:
        with self._out.guard():  # a full disk: one line naming the CSV file
            self._csv.writerow(row)

    def frame(self, result: FrameResult, image_bgr: np.ndarray | None) -> None:
        self._row(csv_rows(result, self.columns))

    def step(self, result: StepResult) -> None:
        self._row(csv_rows(result, self.columns))

    def close(self, ok: bool) -> None:
        try:
            if ok:
                with self._out.guard():
                    self._file.close()
                self._out.commit()
        finally:
            with contextlib.suppress(OSError):  # the write that failed said so already
                self._file.close()
            self._out.discard()
