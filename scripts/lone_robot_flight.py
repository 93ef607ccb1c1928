"""How well one robot's rays alone place a lob: a synthetic flight, one camera.

    python scripts/lone_robot_flight.py

Gravity is known, so one camera's rays fix a flight's scale (the flight c + s (p - c)
falls s g, not g): one flight through the rays (``estimator.tracking.flight_fit``, the
``free`` piece) places the ball. The lob is the tests' (tests/estimator/tracking/
test_flights.py: kicked at 3, 1, 4.5 m/s from (1.15, 1, R)), the camera 0.8 m up at the
origin, each ray off by the given sigma both ways across it; the rays start 0.05 s after
the kick. Printed, for each camera rate, sigma and span of rays: the 3-D RMSE at the last
ray over 20 draws, and the fit's own sigma (its covariance's trace).
"""

from __future__ import annotations

import numpy as np

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.rays import BallRay
from estimator.tracking.ballistic import G_MPS2
from estimator.tracking.flight_fit import fit_kink

CAMERA = np.array([0.0, 0.0, 0.8])
KICK = np.array([1.15, 1.0, BALL_RADIUS_M])
VELOCITY = np.array([3.0, 1.0, 4.5])


def ball(tau: float) -> np.ndarray:
    return KICK + VELOCITY * tau + np.array([0.0, 0.0, -0.5 * G_MPS2 * tau * tau])


def ray(p: np.ndarray, sigma: float, rng: np.random.Generator) -> BallRay:
    u = (p - CAMERA) / np.linalg.norm(p - CAMERA)
    exact = BallRay("robot1", tuple(CAMERA), tuple(u), sigma, sigma)
    e_az, e_el = exact.across()
    u = u + rng.normal(0.0, sigma) * e_az + rng.normal(0.0, sigma) * e_el
    u /= np.linalg.norm(u)
    return BallRay("robot1", exact.origin, (float(u[0]), float(u[1]), float(u[2])), sigma,
                   sigma)


def main() -> None:
    print("rate_hz sigma_rad span_s rmse_3d_m fit_sigma_m range_m")
    for span in (0.3, 0.6, 0.85):
        for rate in (20, 40):
            for sigma in (0.001, 0.003, 0.006):
                errors, sigmas = [], []
                for seed in range(20):
                    rng = np.random.default_rng(seed)
                    taus = [0.05 + k / rate for k in range(round(span * rate) + 1)]
                    rays = [(round(t * NS_PER_S), ray(ball(t), sigma, rng)) for t in taus]
                    free = fit_kink(rays, rays[-1][0], "free", "fly")
                    assert free is not None
                    x, P = free.state_at(rays[-1][0])
                    errors.append(float(np.linalg.norm(x[:3] - ball(taus[-1]))))
                    sigmas.append(float(np.sqrt(np.trace(P[:3, :3]))))
                rng_m = float(np.linalg.norm(ball(taus[-1]) - CAMERA))
                print(f"{rate} {sigma} {span} {np.sqrt(np.mean(np.square(errors))):.3f} "
                      f"{np.mean(sigmas):.3f} {rng_m:.2f}")


if __name__ == "__main__":
    main()
