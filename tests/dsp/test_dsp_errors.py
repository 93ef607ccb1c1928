"""One error tree: every package's errors derive from dsp.errors and carry its exit codes."""

from __future__ import annotations

import pytest

import recorder.errors
import replay.errors
from dsp import errors
from dsp.errors import CalibrationError, DspError, InputError, OutputExistsError, UsageError


def test_exit_codes() -> None:
    assert DspError.exit_code == InputError.exit_code == 1
    assert UsageError.exit_code == 2
    assert OutputExistsError.exit_code == 3
    assert CalibrationError("c.json", "bad").exit_code == 1
    assert issubclass(CalibrationError, InputError)


def test_messages_name_the_value() -> None:
    assert str(CalibrationError("c.json", "not JSON")) == "c.json: unusable calibration: not JSON"
    assert str(OutputExistsError("a/b.mcap")) == (
        "a/b.mcap: output exists already (use --force to overwrite)")


@pytest.mark.parametrize("name", replay.errors.__all__)
def test_replay_errors_are_bad_input(name: str) -> None:
    cls = getattr(replay.errors, name)
    assert issubclass(cls, InputError) and cls.exit_code == 1


def test_packages_define_no_second_usage_overwrite_or_calibration_error() -> None:
    for module in (recorder.errors, replay.errors):
        for name in ("UsageError", "OptionsError", "OutputExistsError", "CalibrationError"):
            assert name not in module.__all__
            assert getattr(module, name, getattr(errors, name, None)) is getattr(
                errors, name, None)
    assert issubclass(recorder.errors.UnknownScenarioError, UsageError)
    assert issubclass(recorder.errors.RendererError, DspError)
    assert recorder.errors.RendererError.exit_code == 4
