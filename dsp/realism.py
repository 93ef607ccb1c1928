"""Named presets of localisation error and camera effects for the recorder (``--realism``).

The recorder's own defaults are a perfect world: every robot knows its pose to the
micrometre and its camera is sharp and noiseless. A preset fills in the less-than-ideal
values in one word, for ``dsp-record`` and ``dsp-eval``; a flag given beside it overrides
that one value. A preset is only a set of values: a log recorded with ``--realism field`` is
the same bytes as one recorded with its values given flag by flag (the log's recording
metadata states each of them), and it is deterministic per seed like any recording.

``field``: what a Middle Size League robot on a real field gets wrong.

- A drifting localisation bias of 0.05 m per axis and 1 deg (an Ornstein-Uhlenbeck process
  with a 5 s time constant, per robot) and white noise of 0.01 m and 0.3 deg on top: the
  tolerances a team's world model allows a standing robot's localisation (Falcons'
  ``worldModel/tst/tolerances.yaml``: 0.03 m and 0.02 rad, 1.1 deg), with the bias drifting
  because a robot's line-based localisation wanders as its view of the lines changes.
- 4 ms exposure (motion blur of a robot driving at 2 m/s: 8 mm), Gaussian image noise of 3
  grey levels and a camera gain wandering by 10 % (auto-exposure under stadium lights).
- In match play, three boxes of the ball's colour beside the field (spectators' things
  the colour of a ball).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from dsp.errors import UsageError

__all__ = ["MATCH_PLAY", "REALISM", "REALISM_PRESETS", "Realism", "realism_preset"]


MATCH_PLAY = ("match", "lobs")
"""The scenarios with match play, which take distractors."""


@dataclass(frozen=True)
class Realism:
    """The values a preset gives the recorder (names as :class:`recorder.record.
    RecordOptions` has them)."""

    pose_bias_m: float = 0.0
    yaw_bias_deg: float = 0.0
    pose_bias_tau_s: float = 5.0
    pose_noise_m: float = 0.0
    yaw_noise_deg: float = 0.0
    exposure_ms: float = 0.0
    image_noise: float = 0.0
    gain_jitter: float = 0.0
    distractors: int = 0
    """Match only: a scenario without match play gets none."""

    def for_scenario(self, scenario: str | None) -> Realism:
        """The preset as ``scenario`` takes it: the distractors only in match play (the
        ``match`` and ``lobs`` scenarios)."""
        return self if scenario in MATCH_PLAY else replace(self, distractors=0)


REALISM_PRESETS: dict[str, Realism] = {
    "none": Realism(),
    "field": Realism(pose_bias_m=0.05, yaw_bias_deg=1.0, pose_bias_tau_s=5.0,
                     pose_noise_m=0.01, yaw_noise_deg=0.3, exposure_ms=4.0, image_noise=3.0,
                     gain_jitter=0.1, distractors=3),
}
"""``none``: the recorder's defaults, a perfect world; ``field``: see the module docstring."""
REALISM = tuple(REALISM_PRESETS)


def realism_preset(name: str) -> Realism:
    """The preset called ``name`` (``UsageError`` naming the choices otherwise)."""
    try:
        return REALISM_PRESETS[name]
    except KeyError:
        raise UsageError(f"unknown realism preset {name!r}; choose one of "
                         f"{', '.join(REALISM)}") from None
