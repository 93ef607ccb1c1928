"""Errors only the recorder raises; they derive from the project's error tree (:mod:`dsp.errors`).

Bad option values raise :class:`dsp.errors.UsageError` (exit 2) and a refused overwrite
:class:`dsp.errors.OutputExistsError` (exit 3); the subclasses here add what is the
recorder's own.
"""

from __future__ import annotations

from dsp.errors import DspError, UsageError

__all__ = [
    "RecorderError",
    "RendererError",
    "UnknownScenarioError",
]


class RecorderError(DspError):
    """The simulation or the recording itself failed (exit code 1)."""


class UnknownScenarioError(UsageError):
    """The scenario name (given or inferred from the file name) is not one we know."""


class RendererError(RecorderError):
    """The requested renderer is not available (e.g. EGL forced on a machine without it)."""

    exit_code = 4
