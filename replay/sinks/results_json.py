"""The results file's form of the records (:mod:`replay.records`): plain, rounded JSON.

The results file is JSON with sorted keys and floats rounded to :data:`DECIMALS` places; it
holds nothing machine-dependent (no wall-clock time, no absolute paths, no timings), so the
same log and options give the same bytes.

Schema (``format`` = "dsp-replay-results", ``version`` = 1)::

    {"format", "version",
     "log": {"file": basename, "sha256", "robots": [...], "recovered": {...} | null},
     "options": {"method", "fusion", "calibration", "pose_tolerance_s", "window_s", ...},
     "frames": [{"frame", "robot", "stamp_ns", "t_s", "status",
                 "detection": {"cx_px", "cy_px", "r_px", "area_px", "bbox_px",
                               "circularity"} | null,
                 "pose": {"x_m", "y_m", "yaw_rad", "gap_s", "interpolated"} | null,
                 "estimate": {"x_m", "y_m", "range_m", "bearing_rad", "visibility",
                              "range_sigma_m", "ray_range_m"} | null,
                 "truth": {"x_m", "y_m"} | null, "error_m": float | null,
                 "localisation": {"x_m", "y_m", "yaw_rad", "covariance": 3 x 3,
                                  "status", "source", "points", "inliers"}}, ...],
     "fused": [{"step", "stamp_ns", "t_s", "robots": [...], "x_m", "y_m",
                "covariance": [[xx, xy], [yx, yy]], "truth": {...} | null,
                "error_m": float | null,
                "velocity_m_s": [vx, vy], "velocity_covariance": [[..], [..]],
                "truth_velocity_m_s": [vx, vy], "velocity_error_m_s": float,
                "z_m", "covariance_3d": 3 x 3, "triangulated", "truth_z_m", "z_error_m",
                "error_3d_m", "vz_m_s",
                "landing": {"stamp_ns", "t_s", "x_m", "y_m"} | null}, ...],
     "summary": {"frames", "steps", "fused_steps", "skipped": {reason: n},
                 "robots": {name: {"frames", "detections", "estimates", "rmse_m", "mean_error_m",
                                   "max_error_m", "errors"}},
                 "fused": {"estimates", "rmse_m", "mean_error_m", "max_error_m", "errors",
                           "velocity": {"errors", "rmse_m_s", "mean_error_m_s",
                                        "max_error_m_s"}},
                 "undecodable_messages",
                 "localisation": {"sources": {source: n}, "statuses": {status: n}},
                 "width": {"lifted": n}}}

``status`` is one of :data:`~replay.records.FRAME_STATUSES`. ``localisation`` is there only
with ``--localise lines``, on the frames with a believed pose: the pose corrected from the
image's field lines, which the estimate is located from, beside the believed ``pose``; its
covariance over (x, y, yaw) [m^2, m rad, rad^2], the fit's ``status`` ("ok",
"too_few_points", "poor_fit", "jump", "no_camera") and the pose's ``source`` ("lines",
"held": the robot's last fit carried over, "prior": the believed pose kept); see
:class:`replay.records.Localisation`. Errors are Euclidean distances
[m] to the ground truth interpolated at the frame's (step's) stamp; RMSE =
sqrt(mean(error^2)). The velocity keys are there only when the fusion estimates a velocity
(``track``): the velocity [m/s] and its covariance [m^2/s^2]; the truth's velocity and the
error's norm [m/s] only when the log holds the ball's true velocity
(``/ground_truth/ball/odometry``), and so the summary's ``fused.velocity``. The 3-D keys are
there only when the fusion gives a height (``triangulate``, ``ballistic``, ``track`` with
``--hops``): the height of the ball's centre [m], the 3 x 3 covariance of (x, y, z) [m^2],
whether rays crossed (else the height is assumed, z = R, and the covariance spreads along
a ray; with ``--hops`` a step the ground track gives has z = R and no covariance), and
against the truth's height when the log has one: z - z_true and the 3-D error [m].
``vz_m_s`` and ``landing`` only from the ballistic tracker (``ballistic``): its vertical
velocity [m/s] and where and when it predicts the ball next meets the ground (null while
the ball is not flying). The
estimate's ``range_sigma_m`` and ``ray_range_m`` only with ``--width-range``, on the
estimates whose blob's width placed a ball in the air under itself: the range's sigma
(the width's) and where the blob's ray meets the ground-plane; the summary's ``width``
counts those estimates.
"""

from __future__ import annotations

import json
import math

from dsp.jsonio import Json
from estimator.constants import NS_PER_S
from estimator.estimates import Covariance
from replay.records import FrameResult, Localisation, StepResult

__all__ = ["DECIMALS", "dumps", "frame_to_dict", "localisation_to_dict", "normalise",
           "step_to_dict"]

DECIMALS = 6


def normalise(value: object) -> Json:
    """Round floats to DECIMALS places (-0.0 -> 0.0, non-finite -> None), recursively."""
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            return None
        r = round(value, DECIMALS)
        return 0.0 if r == 0 else r
    if isinstance(value, dict):
        return {str(k): normalise(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [normalise(v) for v in value]
    item = getattr(value, "item", None)
    if item is not None:  # numpy scalar
        return normalise(item())
    raise TypeError(f"cannot write {type(value).__name__} to a results file")


def dumps(value: object) -> str:
    """One results-file value as text: rounded, sorted keys, ASCII, strict JSON."""
    return json.dumps(normalise(value), sort_keys=True, separators=(", ", ": "),
                      ensure_ascii=True, allow_nan=False)


def _rows(c: Covariance) -> list[Json]:
    return [list(row) for row in c]


def frame_to_dict(f: FrameResult) -> dict[str, Json]:
    det = f.detection
    est = f.estimate
    return {
        "frame": f.frame,
        "robot": f.robot,
        "stamp_ns": f.stamp_ns,
        "t_s": f.stamp_ns / NS_PER_S,
        "status": f.status.value,
        "detection": None if det is None else {
            "cx_px": float(det.cx_px), "cy_px": float(det.cy_px), "r_px": f.r_px,
            "area_px": float(det.area_px), "bbox_px": [int(v) for v in det.bbox_px],
            "circularity": float(det.circularity),
        },
        "pose": None if f.pose is None else {
            "x_m": f.pose.x_m, "y_m": f.pose.y_m, "yaw_rad": f.pose.yaw_rad,
            "gap_s": (f.pose_gap_ns or 0) / NS_PER_S, "interpolated": f.pose_interpolated,
        },
        "estimate": None if est is None else {
            "x_m": est.x_m, "y_m": est.y_m, "range_m": est.range_m,
            "bearing_rad": est.bearing_rad, "visibility": est.visibility,
            # only with --width-range: files made without it stay as they were
            **({} if est.range_sigma_m is None else {
                "range_sigma_m": est.range_sigma_m, "ray_range_m": est.ray_range_m}),
        },
        "truth": None if f.truth is None else {"x_m": f.truth[0], "y_m": f.truth[1]},
        "error_m": f.error_m,
        # only when localising: files made without it stay as they were
        **({} if f.localisation is None else {
            "localisation": localisation_to_dict(f.localisation)}),
    }


def localisation_to_dict(loc: Localisation) -> dict[str, Json]:
    """A frame's corrected pose as the results file holds it."""
    return {"x_m": loc.pose.x_m, "y_m": loc.pose.y_m, "yaw_rad": loc.pose.yaw_rad,
            "covariance": [list(row) for row in loc.covariance], "status": loc.status,
            "source": loc.source, "points": loc.points, "inliers": loc.inliers}


def step_to_dict(s: StepResult) -> dict[str, Json]:
    fused = s.fused
    out: dict[str, Json] = {
        "step": s.step,
        "stamp_ns": s.stamp_ns,
        "t_s": s.stamp_ns / NS_PER_S,
        "robots": sorted(f.robot for f in s.frames if f.estimate is not None),
        "fused_robots": None if fused is None else sorted(fused.robots),
        "x_m": None if fused is None else fused.x_m,
        "y_m": None if fused is None else fused.y_m,
        "covariance": None if fused is None else _rows(fused.covariance),
        "truth": None if s.truth is None else {"x_m": s.truth[0], "y_m": s.truth[1]},
        "error_m": s.error_m,
    }
    if not s.frames:  # a tick of --clock's clock: no image in it
        out["tick"] = True
    # velocity keys only where there is a velocity: window fusions' files stay as they were
    if s.velocity_m_s is not None:
        out["velocity_m_s"] = list(s.velocity_m_s)
        out["velocity_covariance"] = (None if s.velocity_covariance is None
                                      else _rows(s.velocity_covariance))
    if s.truth_velocity_m_s is not None:
        out["truth_velocity_m_s"] = list(s.truth_velocity_m_s)
    if s.velocity_error_m_s is not None:
        out["velocity_error_m_s"] = s.velocity_error_m_s
    # 3-D keys only from a 3-D fusion (triangulate): the other files stay as they were
    if fused is not None and fused.z_m is not None:
        out["z_m"] = fused.z_m
        out["covariance_3d"] = (None if fused.covariance_3d is None
                                else [list(row) for row in fused.covariance_3d])
        out["triangulated"] = fused.triangulated
        out["truth_z_m"] = s.truth_z_m
        out["z_error_m"] = s.z_error_m
        out["error_3d_m"] = s.error_3d_m
    if s.vz_m_s is not None:  # the ballistic tracker
        out["vz_m_s"] = s.vz_m_s
        landing = s.landing
        out["landing"] = None if landing is None else {
            "stamp_ns": landing.stamp_ns, "t_s": landing.stamp_ns / NS_PER_S,
            "x_m": landing.x_m, "y_m": landing.y_m}
    return out
