"""A calibration model: the range a quadratic in the pixel radius, up to a horizon.

The contract (``estimator.calibration.Calibration``): a class made with no arguments, with a
``name``, ``range_m(r_px) -> float`` (raising ``estimator.errors.OutOfRangeError`` where the
model gives no range: the frame is then out of range) and ``to_dict()``. Its constants are
the model's own, an example of the simulated cameras' order (about 1.65 cm per pixel), not
a fit: a model of your own camera carries the constants you fitted.
"""

from __future__ import annotations

from typing import Any

from estimator.errors import OutOfRangeError

C_M = (0.05, 0.0165, 1.0e-6)
"""d = C_M[0] + C_M[1] r + C_M[2] r^2 [m], r in pixels."""
MAX_R_PX = 500.0
"""Beyond this radius the model gives no range."""


class QuadraticCalibration:
    name = "example-quadratic"

    def range_m(self, r_px: float) -> float:
        if not 0.0 <= r_px <= MAX_R_PX:
            raise OutOfRangeError(f"r_px = {r_px} is outside [0, {MAX_R_PX}] px, where the "
                                  "example model gives a range")
        return C_M[0] + C_M[1] * r_px + C_M[2] * r_px * r_px

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.name, "c_m": list(C_M), "max_r_px": MAX_R_PX}
