"""The options of the venue's trouble and lobs: checked like the others (one line), stated in
the typed metadata (only when not the default), byte-identical per seed, and at their
defaults the recorder writes the logs it wrote before them."""

from __future__ import annotations

import hashlib
import importlib.util
import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from dsp import contract as c
from dsp.errors import UsageError
from dsp.metadata import RecorderMetadata, RecordingMetadata, ScenarioMetadata
from recorder import cli
from recorder.record import RecordOptions, record

ROOT = Path(__file__).resolve().parents[2]
FAST: dict[str, Any] = {"face_px": 256, "renderer": "tiny"}
DRESSED: dict[str, Any] = {"ball_colour": "yellow", "ball_pattern": "panels", "people": 3,
                           "covers": 1, "light_pools": 2}


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"ball_colour": "red"}, "--ball-colour 'red': choose one of orange, yellow, white"),
    ({"ball_pattern": "stripes"}, "--ball-pattern 'stripes': choose one of plain, panels"),
    ({"people": -1}, r"--people -1: give a whole number in \[0, 30\]"),
    ({"people": 31}, "--people 31"),
    ({"covers": -2}, r"--covers -2: give a whole number in \[0, 16\]"),
    ({"light_pools": 9}, r"--light-pools 9: give a whole number in \[0, 8\]"),
    ({"lob_fraction": math.nan}, r"--lob-fraction nan: give a finite number in \[0, 1\]"),
    ({"lob_fraction": 1.5}, "--lob-fraction 1.5"),
    ({"lob_fraction": -0.1}, "--lob-fraction -0.1"),
])
def test_bad_venue_options_are_refused_when_made(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(UsageError, match=match):
        RecordOptions(**kwargs)


@pytest.mark.parametrize(("args", "message"), [
    (["--scenario", "rolling", "--lob-fraction", "0.5"],
     "--lob-fraction is for the match scenario (lobs kicks only lobs), not rolling"),
    (["--scenario", "lobs", "--lob-fraction", "0.5"], "--lob-fraction is for the match"),
    (["--scenario", "match", "--covers", "4"],
     "--covers 4: give a whole number in [0, 3] (the robots in match)"),
    (["--scenario", "match", "--lob-fraction", "inf"], "--lob-fraction inf: give a finite"),
    (["--scenario", "match", "--ball-colour", "green"], "invalid choice: 'green'"),
    (["--scenario", "match", "--people", "many"], "invalid int value: 'many'"),
])
def test_dsp_record_refuses_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        args: list[str], message: str) -> None:
    out = tmp_path / "x.mcap"
    assert cli.main([str(out), "--frames", "1", "-q", "--renderer", "tiny", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    if message.startswith("invalid"):  # argparse's own: the error line, then the hint
        assert err[0].startswith("dsp-record: error:")
        assert err[1:] == ["Try 'dsp-record --help' for the options."]
        err = err[:1]
    assert len(err) == 1 and message in err[0], err
    assert not list(tmp_path.iterdir())


def test_the_metadata_states_only_what_is_not_the_default() -> None:
    base = {"rate_hz": 5.0, "pose_rate_hz": 10.0, "frames": 3, "camera": "ideal",
            "image_format": "png", "pose_noise_m": 0.0, "yaw_noise_deg": 0.0, "face_px": 1024,
            "physics_hz": 240}
    old = RecordingMetadata.from_json(base)  # a log from before these options
    assert (old.ball_colour, old.ball_pattern, old.people, old.covers, old.light_pools,
            old.lob_fraction) == ("orange", "plain", 0, 0, 0, 0.0)
    assert old.to_json() == base
    new = RecordingMetadata.from_json({**base, "ball_colour": "white", "lob_fraction": 0.25})
    assert new.to_json() == {**base, "ball_colour": "white", "lob_fraction": 0.25}
    assert RecordingMetadata.from_json(new.to_json()) == new
    with pytest.raises(ValueError, match="people = 'two' is not an integer"):
        RecordingMetadata.from_json({**base, "people": "two"})


def _meta(path: Path) -> dict[str, Any]:
    with open(path, "rb") as f:
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    return ScenarioMetadata.from_metadata(meta[c.SCENARIO_METADATA]).params()


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_dressed_lobs_recording_is_the_same_bytes_per_seed(tmp_path: Path) -> None:
    paths = {}
    for name, seed in (("a", 4), ("b", 4), ("other", 5)):
        paths[name] = tmp_path / f"{name}.mcap"
        record(paths[name], RecordOptions(scenario="lobs", seed=seed, frames=2, **FAST,
                                          **DRESSED))
    assert _sha(paths["a"]) == _sha(paths["b"])
    assert _sha(paths["a"]) != _sha(paths["other"])
    params = _meta(paths["a"])
    rec = params["recording"]
    assert {k: rec[k] for k in DRESSED} == DRESSED and rec["lob_fraction"] == 1.0
    scenery = params["scenery"]
    assert (len(scenery["people"]), len(scenery["covers"]), len(scenery["light_pools"])) == (
        3, 1, 2)
    assert json.loads(json.dumps(params)) == params


def test_the_defaults_write_no_new_key(tmp_path: Path) -> None:
    path = tmp_path / "match.mcap"
    record(path, RecordOptions(scenario="match", frames=1, **FAST))
    params = _meta(path)
    assert not {"scenery", "flight"} & set(params)
    assert not {"ball_colour", "ball_pattern", "people", "covers", "light_pools",
                "lob_fraction"} & set(params["recording"])
    assert all("elevation_deg" not in k for k in params["play"]["kicks"])


def _golden_manifest() -> dict[str, Any]:
    manifest: dict[str, Any] = json.loads(
        (ROOT / "logs" / "golden" / "manifest.json").read_text(encoding="ascii"))
    return manifest


def _contents(path: Path) -> tuple[list[tuple[str, int, int, bytes]], dict[str, dict[str, str]],
                                    RecorderMetadata]:
    """A log's messages (topic, stamps, bytes), its metadata records but the recorder's,
    and the recorder's."""
    with path.open("rb") as f:
        reader = make_reader(f)
        messages = [(ch.topic, m.log_time, m.publish_time, m.data)
                    for _, ch, m in reader.iter_messages()]
        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    return messages, metadata, RecorderMetadata.from_metadata(metadata.pop(c.RECORDER_METADATA))


def test_the_defaults_re_record_a_golden_log_byte_for_byte(tmp_path: Path) -> None:
    """scenario1, as scripts/make_golden.py records it (EGL), gives the pinned bytes: the
    new options at their defaults change nothing in the world, the images or the metadata.
    The recorder's metadata names the libraries' versions, so with other versions installed
    every message and every other metadata entry is compared, and the whole file's hash
    only where the versions are the golden's."""
    spec = importlib.util.find_spec("eglRenderer")
    if spec is None:
        pytest.skip("the goldens are EGL's; this machine has no EGL plugin")
    entry = _golden_manifest()["scenes"]["scenario1"]
    path = tmp_path / "scenario1.mcap"
    summary = record(path, RecordOptions(**entry["record"]))
    assert summary.renderer == "egl"
    messages, metadata, recorder = _contents(path)
    golden = _contents(ROOT / "logs" / "golden" / "scenario1.mcap")
    assert (messages, metadata) == golden[:2]
    assert replace(recorder, versions={}) == replace(golden[2], versions={})
    if recorder.versions == golden[2].versions:
        assert _sha(path) == entry["sha256"]
