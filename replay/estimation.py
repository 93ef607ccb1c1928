"""Per-frame estimation: the estimator parts chosen by the options, applied to one image.

:class:`FrameEstimator` is built once per replay from the options and the robots' cameras
(:mod:`replay.cameras`); :meth:`FrameEstimator.estimate` turns one decoded image (and a way
to look up the robot's pose at its stamp) into a :class:`FrameOutcome` whose
:class:`~replay.records.FrameStatus` says how far the image got:

    image --detect--> blob --pose at stamp--> pose --locate--> field estimate
    (BAD_IMAGE)     (DETECT_ERROR,          (NO_POSE)        (OUT_OF_RANGE)      OK
                     NO_DETECTION)

A frame without a ball is not a skipped frame: NO_DETECTION still carries the pose. A blob
beyond the camera's usable radius is OUT_OF_RANGE, as is one its calibration has no range
for. Poses in another frame than the field's (AMCL's ``map``) are turned into the field
frame by the camera description's ``map_to_field`` first; a camera mounted turned adds its
``mount_yaw_deg`` to every bearing (:mod:`replay.cameras`).

:meth:`FrameEstimator.step` fuses one step's frames: a window fusion of their estimates, or
(``track``) the ball tracker fed with each estimate at its own stamp, with its calibrated
covariance (:class:`~estimator.noise.CalibratedNoise`), and read at the step's stamp, with
the ball's velocity; or (``ballistic``) the step's triangulated point fed to the 3-D
tracker, read with its velocity and predicted landing
(:class:`~estimator.fusion.BallisticFusion`; a step of one image, free-running cameras,
gives the tracker its ray at its stamp). The trackers make a step at every image stamp
(:meth:`FrameEstimator.step_window_ns`). With a ``pose_covariance``
(``--pose-uncertainty``) each estimate carries the covariance of the pose it was located
from, which every fusion's noise model adds the ball's share of
(:func:`estimator.noise.localisation_covariance`): the line fit's, else the log pose's, else
that default. Offline (``smooth``), the steps are held back and leave with the RTS
smoother's track once the log is read (:meth:`FrameEstimator.sinks`,
:meth:`FrameEstimator.flush`, :mod:`replay.smoothing`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from dsp.errors import UsageError
from dsp.jsonio import Json
from estimator import fusion
from estimator.constants import BALL_RADIUS_M
from estimator.detection import Detection, detect_ball
from estimator.detection.real import Candidate
from estimator.errors import EstimatorError
from estimator.estimates import (
    Covariance,
    Covariance3,
    FusedEstimate,
    covariance3_rows,
    covariance_rows,
)
from estimator.geometry import RobotPose
from estimator.hops import HopFollower
from estimator.noise import CalibratedNoise, Noise, localisation_covariance
from estimator.tracking import BallTracker, Measurement, TrackState
from estimator.tracking.bias import BiasEstimator
from estimator.tracking.pose_noise import PoseNoiseEstimator
from replay import plugins
from replay.aloft import StillFilter, blob_range_m, ground_xy
from replay.beliefs import beliefs
from replay.cameras import DEFAULT_CENTRE_PX, Cameras
from replay.locators import CorrectedLocator, Locator, PaperLocator
from replay.locators import ball_estimate as _ball
from replay.plugins import Detector
from replay.real_ball import BallFinder
from replay.records import FrameResult, FrameStatus, Localisation, RobotEstimate, StepResult
from replay.sink import Sink
from replay.smoothing import SmoothedSteps
from replay.sync import PoseMatch

__all__ = ["Detected", "FrameEstimator", "FrameOutcome", "Locator", "detect"]


@dataclass(frozen=True)
class FrameOutcome:
    """What the estimator made of one image."""

    status: FrameStatus
    detection: Detection | None = None
    r_px: float | None = None
    """Pixel radius of the blob from the image centre (eq. 3)."""
    pose: PoseMatch | None = None
    estimate: RobotEstimate | None = None
    candidates: tuple[Candidate, ...] = ()
    """The real detector's checked candidates, the winner first (none from the paper's)."""
    localisation: Localisation | None = None


@dataclass(frozen=True)
class Detected:
    """An image's detection, which needs no pose, so it may run ahead of the estimation."""

    status: FrameStatus | None
    """BAD_IMAGE or DETECT_ERROR when detection could not run; None when it ran."""
    detection: Detection | None = None
    candidates: tuple[Candidate, ...] = ()
    """The real detector's checked candidates, the winner first (none from the paper's)."""


def detect(image: np.ndarray | None, finder: BallFinder | None = None,
           detector: Detector | None = None) -> Detected:
    """The ball in a decoded image (None: the image did not decode), by the paper's chain,
    with a ``finder`` the real-ball detector, or ``detector`` (one from outside,
    :mod:`replay.plugins`). Pure and thread-safe."""
    if image is None:
        return Detected(FrameStatus.BAD_IMAGE)
    try:
        if finder is not None:
            real = finder(image)
            return Detected(None, real.detection, real.candidates)
        found = detect_ball(image) if detector is None else detector.detect(image)
    except EstimatorError:
        return Detected(FrameStatus.DETECT_ERROR)
    if found is not None and not isinstance(found, Detection):
        raise UsageError(f"--detector {detector.name if detector else ''}: detect() returned "
                         f"a {type(found).__name__}, not an estimator.detection.Detection")
    return Detected(None, found)


FLIGHT_HOLD_NS = 500_000_000
"""Residuals teach no pose while the 3-D track has the ball in the air and this long [ns]
after (such a ball is placed on the ground, metres from where the others put it)."""
BIAS_SUPPORT_NS = 500_000_000
"""``--localise ball``: a robot's residual teaches its bias only when another robot's
estimate went into the track this recently [ns] (else the track is its own)."""


class FrameEstimator:
    """The estimator as the options choose it: detection, the method's locator, the fusion."""

    def __init__(self, *, method: str, fusion_method: str, cameras: Cameras,
                 smooth: bool = False, noise: str = "cambada",
                 finder: BallFinder | None = None,
                 detector: Detector | None = None,
                 pose_covariance: np.ndarray | None = None, hops: bool = False,
                 bias: BiasEstimator | None = None,
                 width_robots: frozenset[str] = frozenset(), width_checked: bool = False,
                 pose_noise: PoseNoiseEstimator | None = None) -> None:
        self.cameras = cameras
        self.bias = bias
        """``--localise ball``: each robot's pose bias, estimated from the tracker's residuals
        (:mod:`estimator.tracking.bias`); every estimate is located from the believed pose
        plus its robot's bias."""
        self.pose_noise = pose_noise
        """Each robot's pose covariance learnt from the track's residuals
        (:mod:`estimator.tracking.pose_noise`), which an estimate carries when neither its
        line fit nor its log pose gives one (``pose_covariance`` None)."""
        self._accepted_ns: dict[str, int] = {}  # each robot's last accepted estimate's stamp
        self._flying_until_ns: int | None = None  # the ball flew until then (+ the hold)
        self._stated: dict[str, tuple[float, float]] = {}  # the log's pose sigma (m, rad)
        self.pose_covariance = (None if pose_covariance is None
                                else covariance3_rows(np.asarray(pose_covariance, np.float64)))
        """The pose covariance (x, y, yaw) an estimate carries when neither its line fit
        nor its log pose gives one; None: estimates carry none (module docstring)."""
        self.finder = finder
        self._centres = dict(cameras.centres)
        self._heights = {r: m.height_m for r, m in cameras.models.items()}
        calibrated_noise = CalibratedNoise(
            calibrations=dict(self.cameras.calibrations), fit_rms_m=self.cameras.fit_rms_m)
        self.noise: Noise = calibrated_noise
        self.locator: Locator = (
            PaperLocator(self.cameras) if method == "paper"
            else CorrectedLocator(self.cameras, calibrated_noise if width_robots else None,
                                  width_robots))
        self.still, self.checked = StillFilter(), width_robots if width_checked else frozenset()
        self.tracker: BallTracker | None = None
        self.hops: HopFollower | None = None
        """``--hops``: the 3-D track beside the tracker, whose position it gives."""
        self.detector = detector
        if not plugins.is_builtin("fusion", fusion_method):  # a window fusion from outside
            self.fusion = plugins.new_part("fusion", fusion_method)  # its own: a clean state
        elif fusion_method == "track":
            self.fusion = fusion.get_fusion(fusion_method, noise=self.noise)
            self.tracker = BallTracker(record=smooth)
            self.hops = HopFollower(self.noise) if hops else None
        else:  # the window fusions: CAMBADA's NoiseModel unless asked for the calibrated one
            # (triangulate and ballistic always: the 3-D covariance feeds a tracker, and
            # CAMBADA's range law, made for a ground-plane average, puts a lob's height
            # metres wide)
            calibrated = noise == "calibrated" or fusion_method in ("triangulate", "ballistic")
            self.fusion = fusion.get_fusion(
                fusion_method, noise=self.noise if calibrated else None)
        self._deferred: SmoothedSteps | None = None

    @property
    def centres(self) -> Mapping[str, tuple[float, float]]:
        return self._centres

    def centre(self, robot: str) -> tuple[float, float]:
        return self._centres.get(robot, DEFAULT_CENTRE_PX)

    def estimate(self, robot: str, image: np.ndarray | None,
                 pose_at: Callable[[], PoseMatch | None], *,
                 detected: Detected | None = None,
                 localisation: Localisation | None = None, stamp_ns: int = 0) -> FrameOutcome:
        """One image through detection, pose pairing and location. ``pose_at`` looks up the
        robot's pose at the image's stamp (None: none within the tolerance); ``detected``
        is :func:`detect` of the image when it ran already (e.g. ahead, in a thread);
        ``localisation``, the pose corrected from the image's field lines, is the pose the
        ball is located from when given (the believed one stays the outcome's ``pose``);
        ``stamp_ns``, the image's, tells a still lifted blob (:mod:`replay.aloft`)."""
        if detected is None:
            detected = detect(image, self.finder, self.detector)
        outcome = self._locate(robot, detected, pose_at, localisation)
        if outcome.estimate is not None and outcome.detection and robot in self.checked:
            width = blob_range_m(outcome.detection, self.centre(robot))
            outcome = replace(outcome, estimate=self.still.placed(robot, stamp_ns,
                                                                  outcome.estimate, width))
        return replace(outcome, candidates=detected.candidates) if detected.candidates \
            else outcome

    def _locate(self, robot: str, detected: Detected,
                pose_at: Callable[[], PoseMatch | None],
                loc: Localisation | None) -> FrameOutcome:
        if detected.status is not None:
            return FrameOutcome(detected.status)
        det = detected.detection
        r_px = None
        if det is not None:
            cx, cy = self.centre(robot)
            r_px = math.hypot(det.cx_px - cx, det.cy_px - cy)
        pose = pose_at()
        if pose is None:
            return FrameOutcome(FrameStatus.NO_POSE, det, r_px)
        pose = self.field_pose(robot, pose)
        if loc is None and self.bias is not None:
            loc = self._bias_corrected(robot, pose)
        if det is None:
            return FrameOutcome(FrameStatus.NO_DETECTION, pose=pose, localisation=loc)
        usable = self.cameras.usable_radius_px(robot)
        if usable is not None and r_px is not None and r_px > usable:
            return FrameOutcome(FrameStatus.OUT_OF_RANGE, det, r_px, pose, localisation=loc)
        try:
            estimate = self.locator.locate(robot, det, pose.pose if loc is None else loc.pose)
        except EstimatorError:
            return FrameOutcome(FrameStatus.OUT_OF_RANGE, det, r_px, pose, localisation=loc)
        if self.pose_covariance is not None or self.pose_noise is not None:
            estimate = replace(estimate, pose_covariance=self._pose_covariance(robot, pose, loc))
        elif loc is not None and loc.source == "ball":  # the bias's uncertainty, always
            estimate = replace(estimate, pose_covariance=covariance3_rows(
                np.asarray(loc.covariance, np.float64)))
        return FrameOutcome(FrameStatus.OK, det, r_px, pose, estimate, localisation=loc)

    def _bias_corrected(self, robot: str, match: PoseMatch) -> Localisation:
        """The believed pose plus the robot's estimated bias (``--localise ball``), whose
        spread is the one the log states where it states one."""
        assert self.bias is not None
        if match.covariance is not None:
            self.bias.state(robot, self._note_stated(robot, match.covariance))
        pose = match.pose
        (x, y, yaw), cov = self.bias.corrected(robot, pose.x_m, pose.y_m, pose.yaw_rad)
        return Localisation(RobotPose(x, y, yaw), cov, status="ok", source="ball", points=0,
                            inliers=0)

    def _pose_covariance(self, robot: str, pose: PoseMatch,
                         loc: Localisation | None) -> Covariance3 | None:
        """The covariance of the located-from pose: the line fit's (or its held or prior
        one), else the log pose's, else the one learnt, else the one given."""
        if loc is not None:
            return covariance3_rows(np.asarray(loc.covariance, np.float64))
        if pose.covariance is not None:
            return covariance3_rows(self._note_stated(robot, pose.covariance))
        if self.pose_noise is not None:
            return self.pose_noise.covariance(robot)
        return self.pose_covariance

    def _note_stated(self, robot: str, covariance: Sequence[float]) -> np.ndarray:
        """The log's pose covariance (3 x 3), its sigmas kept for the summary."""
        cov = np.asarray(covariance, np.float64).reshape(3, 3)
        self._stated[robot] = (math.sqrt(max(0.0, 0.5 * (cov[0, 0] + cov[1, 1]))),
                               math.sqrt(max(0.0, cov[2, 2])))
        return cov

    def field_pose(self, robot: str, pose: PoseMatch) -> PoseMatch:
        """The believed pose in the field frame: the camera file's map-to-field transform
        applied, when it gives one."""
        transform = self.cameras.map_to_field(robot)
        if transform is None:
            return pose
        x, y, yaw = transform.apply(pose.pose.x_m, pose.pose.y_m, pose.pose.yaw_rad)
        cov = pose.covariance
        if cov is not None:  # the position's axes turned with the frame; the yaw's stays
            c, s = math.cos(transform.yaw_rad), math.sin(transform.yaw_rad)
            rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            turned = rot @ np.asarray(cov, np.float64).reshape(3, 3) @ rot.T
            cov = tuple(float(v) for v in turned.ravel())
        return replace(pose, pose=RobotPose(x, y, yaw), covariance=cov)

    def sinks(self, sinks: Sequence[Sink]) -> list[Sink]:
        """The sinks the runner feeds: these, or (smoothing) one that passes frames on and
        holds the steps back until :meth:`flush`."""
        if self.tracker is None or not self.tracker.record:
            return list(sinks)
        self._deferred = SmoothedSteps(self.tracker, list(sinks))
        return [self._deferred]

    def beliefs(self) -> dict[str, dict[str, Json]]:
        """What the replay came to believe of each robot's pose (:func:`replay.beliefs.beliefs`)."""
        return beliefs(list(self.cameras.specs), self.pose_noise if self.bias is None
                       else self.bias.learnt, self.bias, self._stated, self.tracker)

    def flush(self) -> None:
        """Once the log is read: the held-back steps, smoothed, to the sinks."""
        if self._deferred is not None:
            self._deferred.flush()

    def step_window_ns(self, window_ns: int) -> int:
        """The window that groups frames into steps: the fusion window, or 1 ns for the
        trackers (``track``, ``ballistic``), which give a fused estimate at every image
        stamp (synchronised cameras' images share theirs)."""
        tracked = self.tracker is not None or isinstance(self.fusion, fusion.BallisticFusion)
        return 1 if tracked else window_ns

    def step(self, index: int, stamp_ns: int, frames: tuple[FrameResult, ...],
             truth: tuple[float, float] | None,
             truth_velocity: tuple[float, float] | None = None,
             truth_z: float | None = None) -> StepResult:
        """One fusion step at ``stamp_ns`` from its frames (in robot order), scored against
        the truth when given."""
        velocity = velocity_cov = None
        flight: fusion.BallisticStep | None = None
        balls = [_ball(f.estimate, f.r_px, self._heights.get(f.robot))
                 for f in frames if f.estimate is not None]
        if isinstance(self.fusion, fusion.BallisticFusion):
            flight = self.fusion.step(stamp_ns, balls)
            fused = None if flight is None else flight.fused
            if flight is not None:
                velocity = flight.velocity[:2]
                velocity_cov = covariance_rows(flight.velocity_covariance)
        elif isinstance(self.fusion, fusion.TimedFusion):  # a tracker from outside
            fused = self.fusion.fuse_at(stamp_ns, balls)
        elif self.tracker is None:
            fused = self.fusion.fuse(balls) if balls else None
        else:
            fused, velocity, velocity_cov = self._track(self.tracker, stamp_ns, frames)
        err = None
        if fused is not None and truth is not None:
            err = math.hypot(fused.x_m - truth[0], fused.y_m - truth[1])
        return StepResult(index, stamp_ns, frames, fused, truth, err, velocity_m_s=velocity,
                          velocity_covariance=velocity_cov, truth_velocity_m_s=truth_velocity,
                          truth_z_m=truth_z,
                          vz_m_s=None if flight is None else flight.velocity[2],
                          landing=None if flight is None else flight.landing)

    def _track(self, tracker: BallTracker, stamp_ns: int, frames: tuple[FrameResult, ...]) -> (
        tuple[FusedEstimate | None, tuple[float, float] | None, Covariance | None]
    ):
        """Each frame's estimate into the tracker at its own stamp; the track at stamp_ns
        (with ``--hops``, its position the 3-D track's, :mod:`estimator.hops`)."""
        hops, taken = self.hops, []
        for f in frames:
            if f.estimate is None:
                continue
            ground = ground_xy(f.estimate)  # a ball in the air: no pose is learnt from it
            prior = self._bias_prior(tracker, f) if ground is None else None
            if self.pose_noise is not None and ground is None:
                self._learn_pose_noise(tracker, f)
            ball_estimate = _ball(f.estimate, f.r_px)
            sigma = self.noise.covariance(ball_estimate)
            shared = (None if f.estimate.pose_covariance is None
                      else covariance_rows(localisation_covariance(ball_estimate)))
            accepted = tracker.update(Measurement(f.stamp_ns, f.robot, f.estimate.x_m,
                                                  f.estimate.y_m, covariance_rows(sigma), shared,
                                                  ground))
            if prior is not None and accepted:
                self._learn_bias(f, prior)
            if accepted:
                self._accepted_ns[f.robot] = f.stamp_ns
                if ground is not None:  # the ball flies: no residual tells a pose meanwhile
                    self._flying_until_ns = f.stamp_ns + FLIGHT_HOLD_NS
            ball = _ball(f.estimate, f.r_px, self._heights.get(f.robot))
            if hops is not None and hops.takes(ball, accepted, tracker.state_at(f.stamp_ns),
                                               f.stamp_ns):
                taken.append(ball)
        state = tracker.state_at(stamp_ns)
        confirmed = state if state is not None and state.confirmed else None
        flight = None
        if hops is not None:  # a step without frames is a clock's tick: it only reads
            flight = (hops.step(stamp_ns, taken, confirmed) if frames
                      else hops.peek(stamp_ns, confirmed))
        if confirmed is None:  # a tentative track may be a false blob
            return None, None, None
        robots = tracker.accepted_at(stamp_ns)
        if hops is not None and hops.airborne and frames:
            self._flying_until_ns = stamp_ns + FLIGHT_HOLD_NS
        if flight is not None:  # the 3-D track's position, its height with it
            fused = replace(flight, robots=robots)
        else:  # the ground track's: with --hops a ball on the ground, its centre at R
            fused = FusedEstimate(confirmed.x_m, confirmed.y_m, confirmed.position_covariance,
                                  robots, z_m=None if hops is None else BALL_RADIUS_M)
        return fused, (confirmed.vx_m_s, confirmed.vy_m_s), confirmed.velocity_covariance

    def _bias_prior(self, tracker: BallTracker, f: FrameResult) -> TrackState | None:
        """``--localise ball``: the confirmed track at the frame's stamp before its estimate
        goes in, the reference its robot's bias is measured against (None: none)."""
        if self.bias is None or f.localisation is None or f.localisation.source != "ball":
            return None
        if not self._supporters(f):
            return None  # a track of this robot's own estimates tells nothing of its bias
        state = tracker.state_at(f.stamp_ns)
        return state if state is not None and state.confirmed else None

    def _supporters(self, f: FrameResult) -> list[str]:
        """The other robots whose estimates went into the track within
        :data:`BIAS_SUPPORT_NS` before the frame; none while the ball flies
        (:data:`FLIGHT_HOLD_NS`), when a residual tells nothing of a pose."""
        if self._flying_until_ns is not None and f.stamp_ns <= self._flying_until_ns:
            return []
        return [r for r, t in self._accepted_ns.items()
                if r != f.robot and f.stamp_ns - t <= BIAS_SUPPORT_NS]

    def _learn_pose_noise(self, tracker: BallTracker, f: FrameResult) -> None:
        """The frame's residual against the track the other robots support, before its
        estimate goes in, into its robot's pose covariance: the one its estimates carry
        where the log states none, and what a stated one is checked against."""
        assert self.pose_noise is not None and f.estimate is not None
        if f.localisation is not None:
            return  # the line fit's or the bias filter's: they learn their own
        others = self._supporters(f)
        if not others:
            return
        state = tracker.state_at(f.stamp_ns)
        if state is None or not state.confirmed:
            return
        est = f.estimate
        own = self.noise.covariance(_ball(replace(est, pose_covariance=None), f.r_px))
        expected = own + np.asarray(state.position_covariance, np.float64)
        self.pose_noise.observe(f.robot, f.stamp_ns, (est.x_m - state.x_m, est.y_m - state.y_m),
                                (est.x_m - est.robot_x_m, est.y_m - est.robot_y_m), expected,
                                len(others) + 1)

    def _learn_bias(self, f: FrameResult, prior: TrackState) -> None:
        """The frame's residual against the track into its robot's bias filter."""
        assert self.bias is not None and f.estimate is not None and f.localisation is not None
        est, corr, believed = f.estimate, f.localisation.pose, f.pose
        if believed is None:
            return
        used = (corr.x_m - believed.x_m, corr.y_m - believed.y_m,
                math.remainder(corr.yaw_rad - believed.yaw_rad, math.tau))
        # the estimate's own noise (not the bias's share, which the filter holds) and the
        # track's uncertainty
        own = self.noise.covariance(_ball(replace(est, pose_covariance=None), f.r_px))
        cov = own + np.asarray(prior.position_covariance, np.float64)
        self.bias.update(f.robot, f.stamp_ns, (prior.x_m - est.x_m, prior.y_m - est.y_m),
                         (est.x_m - corr.x_m, est.y_m - corr.y_m), covariance_rows(cov), used,
                         supporters=1 + len(self._supporters(f)))
