"""``--realism field``: a real field's localisation error and camera effects in one word,
the same bytes as its values given flag by flag, deterministic per seed, a flag beside it
overriding its value; ``dsp-eval --realism`` names its logs and tables after it."""

from __future__ import annotations

import argparse
import hashlib
import json
from pathlib import Path

import pytest
from mcap.reader import make_reader

from dsp import contract as c
from dsp.errors import UsageError
from dsp.metadata import ScenarioMetadata
from dsp.realism import REALISM_PRESETS, realism_preset
from recorder import cli
from replay.evaluate import cli as eval_cli
from replay.evaluate.match import MatchOptions, match_log_name

FAST = ["--face-px", "256", "--renderer", "tiny", "-q"]
FIELD_FLAGS = ["--pose-bias", "0.05", "--yaw-bias", "1", "--pose-bias-tau", "5",
               "--pose-noise", "0.01", "--yaw-noise", "0.3", "--exposure", "4",
               "--image-noise", "3", "--gain-jitter", "0.1", "--distractors", "3"]


def _record(path: Path, *args: str) -> Path:
    assert cli.main([str(path), "--frames", "3", *FAST, *args]) == 0
    return path


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _params(path: Path) -> dict:
    with open(path, "rb") as f:
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    return ScenarioMetadata.from_metadata(meta[c.SCENARIO_METADATA]).params()


def _pose_errors(path: Path) -> list[float]:
    """Believed minus true x of every robot's pose messages, in order."""
    from mcap_ros2.decoder import DecoderFactory

    robots = ("robot1", "robot2", "robot3")
    wanted = {c.topic_for(t, r) for t in (c.POSE_TOPIC, c.GT_POSE_TOPIC) for r in robots}
    topics: dict[str, list[float]] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _s, ch, _m, ros in reader.iter_decoded_messages(topics=sorted(wanted)):
            topics.setdefault(ch.topic, []).append(ros.pose.position.x)
    out = []
    for robot in robots:
        believed = topics[c.topic_for(c.POSE_TOPIC, robot)]
        truth = topics[c.topic_for(c.GT_POSE_TOPIC, robot)]
        out += [b - t for b, t in zip(believed, truth, strict=True)]
    return out


@pytest.fixture(scope="module")
def matches(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("realism")
    return {
        "preset": _record(d / "a.mcap", "--scenario", "match", "--seed", "5", "--realism",
                          "field"),
        "again": _record(d / "b.mcap", "--scenario", "match", "--seed", "5", "--realism",
                         "field"),
        "flags": _record(d / "c.mcap", "--scenario", "match", "--seed", "5", *FIELD_FLAGS),
        "seed6": _record(d / "d.mcap", "--scenario", "match", "--seed", "6", "--realism",
                         "field"),
        "exact": _record(d / "e.mcap", "--scenario", "match", "--seed", "5"),
    }


def test_the_preset_is_its_values_given_flag_by_flag(matches: dict[str, Path]) -> None:
    assert _sha(matches["preset"]) == _sha(matches["again"]) == _sha(matches["flags"])
    params = _params(matches["preset"])
    rec = params["recording"]
    assert (rec["pose_bias_m"], rec["yaw_bias_deg"], rec["pose_bias_tau_s"]) == (0.05, 1.0, 5.0)
    assert (rec["pose_noise_m"], rec["yaw_noise_deg"]) == (0.01, 0.3)
    assert (rec["exposure_ms"], rec["image_noise"], rec["gain_jitter"]) == (4.0, 3.0, 0.1)
    assert len(params["play"]["distractors"]) == 3
    assert params["recording"] != _params(matches["exact"])["recording"]


def test_the_error_is_there_and_differs_per_seed(matches: dict[str, Path]) -> None:
    exact = _pose_errors(matches["exact"])
    assert max(abs(e) for e in exact) < 1e-6
    five, six = _pose_errors(matches["preset"]), _pose_errors(matches["seed6"])
    rms = (sum(e * e for e in five) / len(five)) ** 0.5
    assert 0.005 < rms < 0.2  # centimetres: 5 cm of bias and 1 cm of noise per axis
    assert five != six


def test_a_flag_beside_the_preset_overrides_its_value(tmp_path: Path) -> None:
    log = _record(tmp_path / "scenario1.mcap", "--realism", "field", "--pose-bias", "0",
                  "--image-noise", "1.5")
    params = _params(log)
    rec = params["recording"]
    assert (rec["pose_bias_m"], rec["yaw_bias_deg"], rec["image_noise"]) == (0.0, 1.0, 1.5)
    # a still-ball scenario (named by the file) has no distractors to take
    assert not (params.get("play") or {}).get("distractors")


def test_presets_and_a_bad_name() -> None:
    assert REALISM_PRESETS["none"].pose_bias_m == 0 and REALISM_PRESETS["none"].distractors == 0
    assert realism_preset("field").for_scenario("scenario2").distractors == 0
    assert realism_preset("field").for_scenario("match").distractors == 3
    with pytest.raises(UsageError, match="none, field"):
        realism_preset("stadium")


def test_dsp_eval_names_its_logs_and_tables_after_the_preset(tmp_path: Path) -> None:
    plain, field = MatchOptions(), MatchOptions(realism="field")
    assert match_log_name(1, "random", plain) == "match-1-random-ideal-d3-10s.mcap"
    assert match_log_name(1, "random", field) == "match-1-random-ideal-d3-10s-field.mcap"
    args = eval_cli.build_parser().parse_args(["--suite", "paper", "--realism", "field",
                                               "--out-dir", str(tmp_path), "--camera",
                                               "mirror"])
    assert eval_cli._stem(args) == "paper-mirror-field"
    assert eval_cli._log_dir(args) == tmp_path / "realism-field"
    args = eval_cli.build_parser().parse_args(["--out-dir", str(tmp_path)])
    assert (eval_cli._stem(args), eval_cli._log_dir(args)) == ("paper-ideal", tmp_path)
    assert isinstance(args, argparse.Namespace) and json.dumps(args.realism) == '"none"'


@pytest.mark.parametrize("suite", ["paper", "random"])
def test_dsp_eval_makes_the_presets_log_folder(tmp_path: Path, suite: str,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """A fresh --out-dir with --realism field: the suite's logs go to a folder of it that
    must be made, not refused as missing."""
    seen: list[Path] = []

    def record_nothing(record: object, workdir: Path, **kwargs: object) -> None:
        seen.append(workdir)
        raise SystemExit(0 if workdir.is_dir() else 9)

    monkeypatch.setattr(eval_cli, f"run_{suite}_suite", record_nothing)
    out = tmp_path / "fresh" / "eval"
    code = eval_cli.main(["--suite", suite, "--realism", "field", "--out-dir", str(out), "-q"])
    assert seen == [out / "realism-field"] and code == 0
