"""Evaluation: record scenes, replay them under each configuration, score them (``dsp-eval``).

- :mod:`replay.evaluate.scenes`: one scene of a suite as a picklable task
  (:class:`SceneTask`, :func:`run_scene`);
- :mod:`replay.evaluate.suites`: the ``paper`` suite (the paper's Table 1) and the
  ``random`` suite;
- :mod:`replay.evaluate.match`: the ``match`` suite (the tracker against window fusion);
- :mod:`replay.evaluate.foreign`: logs in a team's layout drawn without the recorder (its
  own camera, :mod:`~replay.evaluate.foreign_render`, and motion,
  :mod:`~replay.evaluate.foreign_scene`), and :mod:`replay.evaluate.foreign_suite`, the
  ``foreign`` suite that scores the default pipeline on them;
- :mod:`replay.evaluate.cli`: the thin command.

The only part of replay that imports the recorder (to record the scenes it scores).
"""

from __future__ import annotations

from replay.evaluate.match import (
    MatchLogScore,
    MatchOptions,
    MatchSuite,
    MatchTask,
    match_markdown,
    run_match_suite,
    run_match_task,
)
from replay.evaluate.scenes import CONFIGS, Config, SceneTask, run_scene, serial_map
from replay.evaluate.suites import (
    DISTANCE_BANDS_M,
    PAPER_RMSE_M,
    PAPER_SCENARIOS,
    PAPER_TABLE1,
    PAPER_TRUTH,
    PaperSuite,
    RandomSuite,
    paper_markdown,
    random_markdown,
    run_paper_suite,
    run_random_suite,
)

__all__ = [
    "CONFIGS",
    "DISTANCE_BANDS_M",
    "PAPER_RMSE_M",
    "PAPER_SCENARIOS",
    "PAPER_TABLE1",
    "PAPER_TRUTH",
    "Config",
    "MatchLogScore",
    "MatchOptions",
    "MatchSuite",
    "MatchTask",
    "PaperSuite",
    "RandomSuite",
    "SceneTask",
    "match_markdown",
    "paper_markdown",
    "random_markdown",
    "run_match_suite",
    "run_match_task",
    "run_paper_suite",
    "run_random_suite",
    "run_scene",
    "serial_map",
]
