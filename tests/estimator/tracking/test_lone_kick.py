"""A lone refused estimate after a bounce: the kick goes where the ball's speed stays real.

The estimates are a tracker's input from a foreign log (``dsp-eval --suite foreign
--foreign-set check``, seed 3111: exact poses, the line fit, a mirror camera), 2.0-2.85 s,
each robot's estimate and its covariance R, rounded. The ball rolls at about (-0.68, 1.88)
m/s and bounces off at about 2.72 s to (-0.53, -1.44) m/s (the log's truth). r2's first
image after the bounce, at 2.7444 s, passes the gate 10 cm behind the ball; r1's, 5.6 ms
later, is refused. A kick between the two made the ball 12.9 m/s fast.
"""

from __future__ import annotations

import math

from estimator.tracking import BallTracker, Measurement, TrackerParams

ROWS = [  # (stamp [0.1 ms], robot, x [m], y [m], R xx, R xy, R yy [m^2])
    (20000, 'r1', -0.0044, 4.4788, 0.001786, 0.000494, 0.000222),
    (20407, 'r3', -0.1377, 4.6274, 0.017906, -0.016657, 0.016043),
    (20444, 'r2', -0.0468, 4.5857, 0.000922, 0.000937, 0.001117),
    (20500, 'r1', -0.0446, 4.5913, 0.001798, 0.00055, 0.000257),
    (20907, 'r3', -0.1782, 4.7323, 0.018732, -0.017616, 0.017134),
    (20944, 'r2', -0.0862, 4.7002, 0.000919, 0.000983, 0.001232),
    (21000, 'r1', -0.096, 4.6979, 0.001797, 0.000602, 0.000293),
    (21407, 'r3', -0.2406, 4.8685, 0.019865, -0.018906, 0.018584),
    (21444, 'r2', -0.127, 4.81, 0.000913, 0.001026, 0.001349),
    (21500, 'r1', -0.1335, 4.8064, 0.001817, 0.000662, 0.000335),
    (21944, 'r2', -0.1715, 4.9103, 0.000901, 0.001062, 0.00146),
    (22000, 'r1', -0.1741, 4.9159, 0.001839, 0.000723, 0.000382),
    (22444, 'r2', -0.2099, 5.0171, 0.000898, 0.001106, 0.001592),
    (22500, 'r1', -0.2016, 5.0266, 0.00188, 0.000794, 0.000437),
    (22944, 'r2', -0.2529, 5.1131, 0.000887, 0.001143, 0.00172),
    (23000, 'r1', -0.2443, 5.1282, 0.001896, 0.000855, 0.000491),
    (23444, 'r2', -0.2747, 5.2354, 0.000902, 0.001212, 0.001902),
    (23500, 'r1', -0.2964, 5.2212, 0.001898, 0.000907, 0.000543),
    (23944, 'r2', -0.3246, 5.3261, 0.000886, 0.001241, 0.002037),
    (24000, 'r1', -0.3221, 5.3286, 0.00195, 0.000987, 0.000614),
    (24444, 'r2', -0.3546, 5.4319, 0.000888, 0.001294, 0.002211),
    (24500, 'r1', -0.3557, 5.4329, 0.001991, 0.001064, 0.000688),
    (24944, 'r2', -0.3945, 5.5265, 0.000881, 0.001335, 0.002378),
    (25000, 'r1', -0.395, 5.5272, 0.00202, 0.001134, 0.000761),
    (25444, 'r2', -0.4257, 5.6334, 0.000884, 0.001392, 0.002583),
    (25500, 'r1', -0.4372, 5.6213, 0.002047, 0.001204, 0.00084),
    (25944, 'r2', -0.4543, 5.7441, 0.00089, 0.001457, 0.002812),
    (26000, 'r1', -0.4671, 5.7228, 0.002102, 0.001294, 0.000934),
    (26444, 'r2', -0.4957, 5.826, 0.000877, 0.001487, 0.002984),
    (26500, 'r1', -0.4874, 5.824, 0.002174, 0.001395, 0.00104),
    (26944, 'r2', -0.5219, 5.935, 0.000883, 0.001553, 0.003238),
    (27000, 'r1', -0.5262, 5.915, 0.002212, 0.001477, 0.001139),
    (27444, 'r2', -0.5541, 5.8774, 0.000837, 0.001472, 0.003089),
    (27500, 'r1', -0.5529, 5.8421, 0.002188, 0.001427, 0.001079),
    (27944, 'r2', -0.5752, 5.7894, 0.000793, 0.001381, 0.002883),
    (28000, 'r1', -0.5761, 5.7433, 0.00216, 0.001359, 0.000999),
    (28444, 'r2', -0.588, 5.6515, 0.000743, 0.001262, 0.002583),
    (28500, 'r1', -0.5863, 5.6169, 0.002148, 0.001284, 0.000905),
]
AFTER_BOUNCE_M_S = (-0.53, -1.44)


def _track() -> list[tuple[float, str, float, float]]:
    tracker = BallTracker()
    out = []
    for tenths, robot, x, y, a, b, d in ROWS:
        stamp = tenths * 100_000
        tracker.update(Measurement(stamp, robot, x, y, ((a, b), (b, d))))
        s = tracker.state_at(stamp)
        assert s is not None
        out.append((stamp / 1e9, robot, s.vx_m_s, s.vy_m_s))
    return out


def test_a_lone_kick_after_a_bounce_leaves_the_ball_no_faster_than_a_ball_runs() -> None:
    fastest = TrackerParams().max_speed_m_s
    after = [(t, vx, vy) for t, _, vx, vy in _track() if t >= 2.749]
    assert after
    for t, vx, vy in after:
        assert math.hypot(vx, vy) <= fastest, t
    t, vx, vy = after[0]  # r1's image, 5.6 ms after r2's first one after the bounce
    assert math.hypot(vx - AFTER_BOUNCE_M_S[0], vy - AFTER_BOUNCE_M_S[1]) < 0.5


def test_before_the_bounce_the_track_is_unchanged() -> None:
    before = [(vx, vy) for t, _, vx, vy in _track() if 2.5 <= t < 2.72]
    assert before
    for vx, vy in before:
        assert math.hypot(vx + 0.68, vy - 1.88) < 0.3
