"""Errors the recorder raises on purpose; the CLI maps each to a one-line message and exit code."""

from __future__ import annotations

__all__ = [
    "OutputExistsError",
    "RecorderError",
    "RendererError",
    "UnknownScenarioError",
    "UsageError",
]


class RecorderError(Exception):
    """Base class: a known, explainable failure of a recording."""

    exit_code = 1


class UsageError(RecorderError):
    """An option value is out of range or inconsistent with another."""

    exit_code = 2


class UnknownScenarioError(UsageError):
    """The scenario name (given or inferred from the file name) is not one we know."""


class OutputExistsError(RecorderError):
    """The output log exists and overwriting was not asked for (--force)."""

    exit_code = 3


class RendererError(RecorderError):
    """The requested renderer is not available (e.g. EGL forced on a machine without it)."""

    exit_code = 4
