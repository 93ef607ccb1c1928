"""Fusing several robots' ball estimates into one, behind the :class:`Fusion` protocol.

- ``mean``: the paper's plain average (eq. 20-21).
- ``nearest``: the estimate of the robot nearest the ball (smallest ``range_m``), as NuBot
  and CAMBADA do.
- ``weighted``: inverse-covariance weighting of all estimates.
- ``robust``: ``weighted`` with iterative n-sigma outlier rejection (Falcons).
- ``triangulate``: each estimate as a ray (:mod:`estimator.rays`), two or more rays crossed
  into a 3-D point, with rejection of rays that do not meet the others; the ground-plane
  ``robust`` fusion, at z = R and a covariance saying the height is unknown, otherwise.
- ``track``: the ball tracker (:mod:`estimator.tracking`), a Kalman filter over position and
  velocity; as a one-shot :class:`Fusion` it gates the estimates against each other.
- ``ballistic``: each step's ``triangulate`` point, or one image's ray at its own stamp, fed
  to the ballistic tracker (:mod:`estimator.tracking.ballistic`): the ball in 3-D with its
  velocity through flight, bounces and rolling, and where it will land.

Each method takes its per-estimate covariances from a noise model (:mod:`estimator.noise`).
All methods are deterministic: no randomness, ties broken by input order (``nearest``'s
by robot name first), and the ``robots`` of a result are listed in input order.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol, runtime_checkable

import numpy as np

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.errors import EstimatorError, FusionError, UnknownFusionError
from estimator.estimates import (
    BallEstimate,
    FusedEstimate,
    Matrix,
    covariance3_rows,
    covariance_rows,
)
from estimator.noise import CalibratedNoise, Noise, NoiseModel
from estimator.rays import BallRay, Point3, aloft, height_unknown_covariance, ray_of, triangulate
from estimator.tracking.ballistic import BallisticParams, BallisticTracker, Landing
from estimator.tracking.flights import FlightFollower
from estimator.tracking.one_shot import TrackFusion
from estimator.tracking.ray_pairs import RayPairs, ray_residual

__all__ = [
    "FUSION_METHODS",
    "RANGE_TIE_M",
    "BallisticFusion",
    "BallisticStep",
    "Fusion",
    "MeanFusion",
    "NearestFusion",
    "RobustFusion",
    "TimedFusion",
    "TriangulateFusion",
    "WeightedFusion",
    "get_fusion",
]

RANGE_TIE_M = 1e-9
"""``nearest``: ranges within this of the smallest tie [m]. A nanometre: far below any
range noise, far above the rounding of one range computed in two frames (1e-15 m)."""


def _fused(position: Matrix, covariance: Matrix, robots: Sequence[str]) -> FusedEstimate:
    cov = 0.5 * (covariance + covariance.T)  # symmetric to rounding
    return FusedEstimate(x_m=float(position[0]), y_m=float(position[1]),
                         covariance=covariance_rows(cov), robots=tuple(robots))


@runtime_checkable
class Fusion(Protocol):
    """Several robots' estimates -> one, or None for no estimates."""

    @property
    def name(self) -> str:
        """The method's name, one of FUSION_METHODS for the built-in ones."""
        ...

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        """The fused estimate of ``estimates`` (None when there are none)."""
        ...


@runtime_checkable
class TimedFusion(Fusion, Protocol):
    """A fusion that keeps time, as a tracker does: the replay calls :meth:`fuse_at` at every
    step, in time order, with the step's stamp, also when no robot saw the ball (a tracker
    may predict then), instead of :meth:`Fusion.fuse`, which stays its one-shot form."""

    def fuse_at(self, stamp_ns: int,
                estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        """The fused estimate at ``stamp_ns`` [ns] after ``estimates``, the step's (maybe
        none), or None for no estimate."""
        ...


@dataclass(frozen=True)
class MeanFusion:
    """The paper's eq. 20-21: x = mean(x_i), y = mean(y_i).

    Covariance: the sample covariance of the estimates divided by n (the covariance of
    the mean); for a single estimate, the noise model's covariance of that estimate.
    """

    noise: Noise = field(default_factory=NoiseModel)

    @property
    def name(self) -> str:
        return "mean"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        points = np.array([[e.x_m, e.y_m] for e in estimates])
        n = len(estimates)
        mean = points.mean(axis=0)  # eq. 20-21
        if n == 1:
            covariance = self.noise.covariance(estimates[0])
        else:
            centred = points - mean
            covariance = centred.T @ centred / (n - 1) / n
        return _fused(mean, covariance, [e.robot for e in estimates])


@dataclass(frozen=True)
class NearestFusion:
    """The estimate with the smallest ``range_m``, its covariance from the noise model.

    Ranges within :data:`RANGE_TIE_M` of the smallest are a tie, won by the robot whose name
    sorts first (then by the first given): the same scene in any frame (rotated, shifted)
    picks the same robot, where comparing the floats alone would let rounding decide."""

    noise: Noise = field(default_factory=NoiseModel)

    @property
    def name(self) -> str:
        return "nearest"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        first = min(estimates, key=lambda e: e.range_m)
        tied = [e for e in estimates if e.range_m - first.range_m <= RANGE_TIE_M]
        best = min(tied or [first], key=lambda e: e.robot)  # min keeps the first on ties
        return _fused(np.array([best.x_m, best.y_m]), self.noise.covariance(best), [best.robot])


def _information_fuse(points: Matrix, covariances: Sequence[Matrix]) -> tuple[Matrix, Matrix]:
    """Inverse-covariance weighting: P = (sum Sigma_i^-1)^-1, x = P sum Sigma_i^-1 x_i."""
    information = np.zeros((2, 2))
    weighted_sum = np.zeros(2)
    for point, sigma in zip(points, covariances, strict=True):
        inverse = np.linalg.inv(sigma)
        information += inverse
        weighted_sum += inverse @ point
    covariance = np.asarray(np.linalg.inv(information), dtype=np.float64)
    return covariance @ weighted_sum, covariance


@dataclass(frozen=True)
class WeightedFusion:
    """Inverse-covariance weighted mean of all estimates (covariances from the noise
    model); its covariance is (sum Sigma_i^-1)^-1."""

    noise: Noise = field(default_factory=NoiseModel)

    @property
    def name(self) -> str:
        return "weighted"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        points = np.array([[e.x_m, e.y_m] for e in estimates])
        position, covariance = _information_fuse(
            points, [self.noise.covariance(e) for e in estimates]
        )
        return _fused(position, covariance, [e.robot for e in estimates])


@dataclass(frozen=True)
class RobustFusion:
    """``weighted`` with iterative n-sigma outlier rejection (as the Falcons do).

    Repeat: fuse the kept estimates; compute each kept estimate's Mahalanobis distance
    m_i = sqrt((x_i - x)^T Sigma_i^-1 (x_i - x)) to the fused x; if the largest m_i
    exceeds ``n_sigma``, drop that one estimate (the first on ties) and fuse again. Stops
    when none exceeds ``n_sigma`` or one estimate is left.
    """

    noise: Noise = field(default_factory=NoiseModel)
    n_sigma: float = 3.0

    def __post_init__(self) -> None:
        if not self.n_sigma > 0.0:
            raise FusionError(f"n_sigma = {self.n_sigma} must be > 0 (3 is usual)")

    @property
    def name(self) -> str:
        return "robust"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        kept = list(range(len(estimates)))
        points = np.array([[e.x_m, e.y_m] for e in estimates])
        sigmas = [self.noise.covariance(e) for e in estimates]
        while True:
            position, covariance = _information_fuse(points[kept], [sigmas[i] for i in kept])
            if len(kept) == 1:
                break
            distances = [
                math.sqrt(
                    float((points[i] - position) @ np.linalg.solve(sigmas[i], points[i] - position))
                )
                for i in kept
            ]
            worst = int(np.argmax(distances))  # argmax keeps the first on ties
            if distances[worst] <= self.n_sigma:
                break
            del kept[worst]
        return _fused(position, covariance, [estimates[i].robot for i in kept])


@dataclass(frozen=True)
class TriangulateFusion:
    """The ball in 3-D from the robots' rays (:func:`estimator.rays.triangulate`).

    Rays from estimates with a ``camera_height_m``, their sigmas from the noise model. Each
    pair of rays fixes a point; the rays within ``n_sigma`` of it (in their sigmas) are its
    support, and the largest support is triangulated (a false blob's ray meets no other).
    Two rays that miss each other by more than ``n_sigma`` do not say which is wrong: the
    ground-plane fusion is used. So it is when the
    rays fix no point (one robot, near-parallel rays): the ``robust`` fusion of the ground
    estimates at z = R, with a 3-D covariance that spreads along the nearest robot's ray up
    to ``top_m`` (:func:`estimator.rays.height_unknown_covariance`).
    """

    noise: Noise = field(default_factory=NoiseModel)
    n_sigma: float = 4.0
    top_m: float = 3.5
    """The highest a ball flies (a lob's apex is at most 3 m) [m]."""

    @property
    def name(self) -> str:
        return "triangulate"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        rays: list[BallRay] = []
        for e in estimates:
            if e.camera_height_m is not None:
                try:
                    rays.append(ray_of(e, self.noise.covariance))
                except EstimatorError:
                    continue
        inliers = self._consistent(rays)
        if inliers:
            solved = triangulate(inliers)
            if solved is not None:
                point, cov = solved
                return FusedEstimate(point[0], point[1], covariance_rows(cov),
                                     tuple(r.robot for r in inliers), z_m=point[2],
                                     covariance_3d=covariance3_rows(cov), triangulated=True)
        return self._on_the_ground(estimates, rays)

    def _consistent(self, rays: Sequence[BallRay]) -> list[BallRay]:
        """The largest set of rays within ``n_sigma`` of the point a pair of them fixes (the
        pairs in input order; on ties the smaller sum of residuals, then the first pair);
        empty when no pair's rays both pass."""
        best: tuple[int, float] = (0, 0.0)
        chosen: list[BallRay] = []
        for i, j in itertools.combinations(range(len(rays)), 2):
            solved = triangulate([rays[i], rays[j]])
            if solved is None:
                continue
            point = np.array(solved[0])
            residuals = [ray_residual(r, point) for r in rays]
            kept = [k for k, res in enumerate(residuals) if res <= self.n_sigma]
            if i not in kept or j not in kept:
                continue
            score = (len(kept), -sum(residuals[k] for k in kept))
            if score > best:
                best, chosen = score, [rays[k] for k in kept]
        return chosen

    def _on_the_ground(self, estimates: Sequence[BallEstimate], rays: Sequence[BallRay]
                       ) -> FusedEstimate | None:
        ground = RobustFusion(self.noise).fuse(estimates)
        if ground is None:
            return None
        cov2 = np.array(ground.covariance)
        nearest = {e.robot: e.range_m for e in estimates}
        used = [r for r in rays if r.robot in ground.robots]
        lifted = [e for e in estimates if e.robot in ground.robots and e.ray_range_m is not None]
        if len(ground.robots) == 1 and len(used) == 1 and lifted:  # in the air, by its width
            return aloft(ground, used[0], lifted[0])
        if used:
            ray = min(used, key=lambda r: (nearest[r.robot], r.robot))
            cov3 = height_unknown_covariance(cov2, ray, self.top_m)
        else:
            cov3 = np.zeros((3, 3))
            cov3[:2, :2] = cov2
            cov3[2, 2] = (self.top_m - BALL_RADIUS_M) ** 2 / 3.0
        return replace(ground, z_m=BALL_RADIUS_M, covariance_3d=covariance3_rows(cov3))


@dataclass(frozen=True)
class BallisticStep:
    """The ballistic track at one step: the fused estimate (x, y, z, their 3 x 3 covariance),
    the velocity (vx, vy, vz, the level part's 2 x 2 covariance), the landing if it flies."""

    fused: FusedEstimate
    velocity: tuple[float, float, float]
    velocity_covariance: Matrix
    landing: Landing | None


class BallisticFusion:
    """``ballistic``: each step's estimates triangulated (:class:`TriangulateFusion`, the
    calibrated noise) and the 3-D point with its covariance fed to a
    :class:`~estimator.tracking.ballistic.BallisticTracker`, read at the step's stamp
    (:meth:`step`). One robot's point says no height (its covariance spreads along the ray)
    and the track's height stays as unknown. A step without a point (no robot saw the
    ball, or a clock tick) gives the track's prediction until ``coast_s`` after its last
    accepted point. ``fuse`` alone is one instant, which has no flight: the triangulation.
    The fused estimate's ``robots`` are the point's when the track took it (none when it
    coasts or refused it); ``triangulated``: this step's point came from crossed rays.

    One robot's image (free-running cameras) has no ray to cross: a flying track takes the
    ray (:meth:`~estimator.tracking.ballistic.BallisticTracker.update_ray`), a rolling one
    the point it crosses another robot's recent ray at (:mod:`~estimator.tracking.ray_pairs`),
    else the ground estimate; every ray since the kick is fitted to one flight
    (:mod:`~estimator.tracking.flights`), which starts, checks and bounces the track."""

    def __init__(self, noise: Noise | None = None, params: BallisticParams | None = None,
                 coast_s: float = 1.0) -> None:
        self.triangulate = TriangulateFusion(noise or CalibratedNoise())
        self.tracker = BallisticTracker(params)
        self.pairs = RayPairs()
        self.flights = FlightFollower()
        self.coast_ns = round(coast_s * NS_PER_S)

    @property
    def name(self) -> str:
        return "ballistic"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        return self.triangulate.fuse(estimates)

    def step(self, stamp_ns: int, estimates: Sequence[BallEstimate]) -> BallisticStep | None:
        """The track at ``stamp_ns`` after this step's estimates (None: no track yet, or
        none seen for ``coast_s``)."""
        tracker = self.tracker
        rays = self._rays(estimates)
        if len(estimates) == 1 and len(rays) == 1:  # one image: its ray at its own stamp
            taken, robots, crossed = self._one_ray(stamp_ns, estimates, rays[0])
        else:
            point = self.triangulate.fuse(estimates) if estimates else None
            taken, robots = False, point.robots if point is not None else ()
            crossed = point is not None and point.triangulated
            if point is not None and point.z_m is not None and point.covariance_3d is not None:
                taken = tracker.update(stamp_ns, (point.x_m, point.y_m, point.z_m),
                                       np.array(point.covariance_3d, dtype=np.float64))
            else:
                tracker.predict(stamp_ns)
        self.flights.step(stamp_ns, rays, tracker)
        for ray in rays:
            self.pairs.remember(stamp_ns, ray)
        last = tracker.last_accepted_ns
        if tracker.x is None or last is None or stamp_ns - last > self.coast_ns:
            return None
        x, P = tracker.x, tracker.P
        fused = FusedEstimate(
            float(x[0]), float(x[1]), covariance_rows(P[:2, :2]), robots if taken else (),
            z_m=float(x[2]), covariance_3d=covariance3_rows(P[:3, :3]), triangulated=crossed)
        return BallisticStep(fused, (float(x[3]), float(x[4]), float(x[5])),
                             0.5 * (P[3:5, 3:5] + P[3:5, 3:5].T), tracker.landing())

    def crossing(self, stamp_ns: int, estimate: BallEstimate) -> Point3 | None:
        """Where ``estimate``'s ray (an image at ``stamp_ns``) crosses another robot's recent
        ray that this track took, moved with the track (:meth:`~estimator.tracking.ray_pairs.
        RayPairs.point`); None without a track, such a ray or a crossing."""
        rays = self._rays([estimate])
        crossed = None if not rays else self.pairs.point(stamp_ns, rays[0], self.tracker)
        return None if crossed is None else crossed[0]

    def offer(self, estimate: BallEstimate) -> None:  # not for the track: the fits' only
        self.flights.offer_all(self._rays([estimate]))

    def _rays(self, estimates: Sequence[BallEstimate]) -> list[BallRay]:
        rays = []
        for e in estimates:
            if e.camera_height_m is not None:
                try:
                    rays.append(ray_of(e, self.triangulate.noise.covariance))
                except EstimatorError:
                    continue
        return rays

    def _one_ray(self, stamp_ns: int, estimates: Sequence[BallEstimate], ray: BallRay
                 ) -> tuple[bool, tuple[str, ...], bool]:
        """One robot's image: a flying track takes its ray; one that rolls (or has no
        height) the point it crosses a recent ray of another robot at, else the image's
        ground estimate with its height unknown. (taken, robots, crossed)."""
        tracker = self.tracker
        if tracker.airborne:
            return tracker.update_ray(stamp_ns, ray), (ray.robot,), False
        paired = self.pairs.point(stamp_ns, ray, tracker)
        if paired is not None:
            return tracker.update(stamp_ns, *paired), (ray.robot,), False
        point = self.triangulate.fuse(estimates)
        if point is None or point.z_m is None or point.covariance_3d is None:
            tracker.predict(stamp_ns)
            return False, (), False
        return tracker.update(stamp_ns, (point.x_m, point.y_m, point.z_m),
                              np.array(point.covariance_3d, dtype=np.float64)), point.robots, False


_METHODS: dict[str, Callable[[Noise | None], Fusion]] = {
    "mean": lambda noise: MeanFusion(noise or NoiseModel()),
    "nearest": lambda noise: NearestFusion(noise or NoiseModel()),
    "weighted": lambda noise: WeightedFusion(noise or NoiseModel()),
    "robust": lambda noise: RobustFusion(noise or NoiseModel()),
    "triangulate": lambda noise: TriangulateFusion(noise or NoiseModel()),
    "track": lambda noise: TrackFusion(noise=noise or CalibratedNoise()),
    "ballistic": lambda noise: BallisticFusion(noise or CalibratedNoise()),
}

FUSION_METHODS = tuple(_METHODS)
"""The built-in methods' names, in the order the module docstring describes them; the
names :func:`get_fusion` accepts."""


def get_fusion(name: str, *, noise: Noise | None = None) -> Fusion:
    """The fusion method called ``name`` (one of FUSION_METHODS), with its defaults: the
    window methods use ``noise`` or :class:`NoiseModel`, ``track`` ``noise`` or
    :class:`CalibratedNoise`."""
    try:
        method = _METHODS[name]
    except KeyError:
        raise UnknownFusionError(
            f"fusion method {name!r} is unknown; use one of {', '.join(FUSION_METHODS)}"
        ) from None
    return method(noise)
