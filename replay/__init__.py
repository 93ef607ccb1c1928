"""Replay an MCAP log offline through the estimator, into Rerun and results files."""

__all__: list[str] = []
