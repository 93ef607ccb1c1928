"""Example estimator parts for dual-sight (see the pyproject's entry points)."""

__version__ = "0.1.0"
