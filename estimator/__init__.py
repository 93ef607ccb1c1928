"""The Dual-Sight Perspective ball estimator: pure numpy + OpenCV, no I/O."""

__all__: list[str] = []
