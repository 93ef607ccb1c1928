"""Profiles: dsp-replay with no switches runs the best pipeline the log allows, says what
ran (one line, and the results header), and ``--profile paper`` is the paper's golden."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from replay.cli import main
from replay.options import ReplayOptions
from replay.profiles import PROFILES, allowances, decide, options_for

GOLDEN = Path(__file__).resolve().parents[2] / "logs" / "golden"


def test_the_default_is_the_best_profile() -> None:
    o = options_for()
    assert (o.profile, o.method, o.fusion_method, o.localise, o.hops, o.pose_uncertainty) == (
        "best", "corrected", "track", "auto", True, True)
    assert options_for("fast").localise == "none"
    p = options_for("paper")
    assert (p.method, p.fusion_method, p.detector_name, p.localise, p.hops,
            p.pose_uncertainty) == ("paper", "mean", "paper", "none", False, False)


def test_a_switch_overrides_one_choice_and_what_it_rules_out_falls_away() -> None:
    o = options_for(fusion="mean")
    assert o.fusion_method == "mean" and o.hops is False  # hops need the tracker
    assert o.localise == "auto" and o.pose_uncertainty is True  # the rest stays
    assert options_for(smooth=True).hops is False
    m = options_for(method="paper")
    assert m.fusion_method == "mean" and not m.hops and not m.pose_uncertainty
    assert options_for(hops=False).hops is False
    assert options_for("paper", fusion="track").hops is False  # the paper profile has none
    with pytest.raises(Exception, match="--hops"):  # an explicit clash is still refused
        options_for(fusion="mean", hops=True)
    with pytest.raises(Exception, match="--profile 'nope'"):
        options_for("nope")


def test_the_paper_s_method_drops_the_line_fit_of_the_profile() -> None:
    """The paper's method corrects no pose: ``--method paper`` under the default profile
    falls to the believed poses, as its fusion falls to the mean; an explicit
    ``--localise`` stays."""
    assert options_for().localise == "auto"
    m = options_for(method="paper")
    assert (m.method, m.localise) == ("paper", "none")
    assert options_for(method="paper", localise=None).localise == "none"
    assert options_for(method="paper", localise="none").localise == "none"
    assert options_for(method="corrected").localise == "auto"  # the profile's own method


def test_what_the_log_lacks_is_said_and_the_part_left_out() -> None:
    best = options_for()
    settled, pipe = decide(best, field="18x12", robots=("r1", "r2"), camera_robots=("r1",))
    assert settled.localise == "lines" and settled.hops and pipe.notes == ()
    settled, pipe = decide(best, field=None, robots=("r1", "r2"), camera_robots=("r1",))
    # no lines: the poses corrected by the biases the robots' balls show, relative to each other
    assert settled.localise == "ball" and pipe.poses == "ball"
    assert pipe.notes == ("no line fit: the log names no field (dsp.scenario metadata); name "
                          "it in the camera file: field: 18x12",)
    settled, pipe = decide(best, field="18x12", robots=("r1",), camera_robots=())
    assert settled.localise == "none" and not settled.hops  # one robot: no one to compare with
    settled, _ = decide(options_for(fusion="mean"), field=None, robots=("r1", "r2"),
                        camera_robots=())
    assert settled.localise == "none"  # the biases are learnt from the tracker's residuals
    assert len(pipe.notes) == 2 and "one robot" in pipe.describe()
    assert "no robot's camera model is known" in pipe.notes[0]
    # the caller's notes (where the field came from) come first
    _, pipe = decide(best, field="22x14", robots=("r1", "r2"), camera_robots=("r1",),
                     notes=("field 22x14 from c.yaml",))
    assert pipe.notes == ("field 22x14 from c.yaml",)
    # options made one by one are left as they are: no profile, no notes
    plain = ReplayOptions(hops=True)
    settled, pipe = decide(plain, field=None, robots=("r1",), camera_robots=())
    assert settled == plain and pipe.profile is None and pipe.notes == ()
    assert set(PROFILES) == {"best", "fast", "paper"}


def test_the_rules_decide_goes_by_say_what_each_part_needs() -> None:
    line_fit, track = allowances(field=None, robots=("r1",), camera_robots=())
    assert not line_fit.allowed and not track.allowed
    assert line_fit.describe() == (
        "line fit: no: the log names no field (dsp.scenario metadata); name it in the camera "
        "file: field: 18x12 and no robot's camera model is known (a camera file's mirror, "
        "fisheye or ideal entry, or a lookup entry with height_m: --cameras FILE)")
    assert track.describe() == "3-D track: no: one robot, no rays to cross"
    line_fit, track = allowances(field="22x14", robots=("r1", "r2", "r3"),
                                 camera_robots=("r1", "r2", "r3"))
    assert line_fit.describe() == "line fit: yes (field 22x14, camera models of 3 robots)"
    assert track.describe() == "3-D track: yes (3 robots)"


def test_a_replay_with_no_switches_records_and_prints_its_pipeline(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "match.mcap"
    shutil.copyfile(GOLDEN / "match.mcap", log)
    out = tmp_path / "r.json"
    assert main([str(log), "--out", str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[0] == ("pipeline (best): paper detector (chosen: the log's dsp-record "
                          "metadata states the colour chain's orange ball), corrected ranges, "
                          "poses corrected from the field lines, pose uncertainty, track fusion "
                          "with hops and flight")
    doc = json.loads(out.read_text())
    assert doc["pipeline"] == {"profile": "best", "detector": "paper", "method": "corrected",
                               "poses": "lines", "pose_uncertainty": True, "fusion": "track",
                               "hops": True, "notes": []}
    assert doc["options"]["localise"] == "lines"  # settled, as it ran
    assert doc == json.loads((GOLDEN / "match.profile-best.json").read_text())


def test_the_paper_profile_is_the_paper_golden(tmp_path: Path) -> None:
    """Every byte of the paper-mode golden but the header's record of the pipeline."""
    log = tmp_path / "scenario1.mcap"
    shutil.copyfile(GOLDEN / "scenario1.mcap", log)
    out = tmp_path / "r.json"
    assert main([str(log), "--profile", "paper", "--out", str(out), "-q"]) == 0
    doc = json.loads(out.read_text())
    assert doc.pop("pipeline") == {"profile": "paper", "detector": "paper", "method": "paper",
                                   "poses": "believed", "pose_uncertainty": False,
                                   "fusion": "mean", "hops": False, "notes": []}
    golden = (GOLDEN / "scenario1.paper-mean.json").read_text()
    assert json.dumps(doc, sort_keys=True) == json.dumps(json.loads(golden), sort_keys=True)
    text = out.read_text()
    start = text.index('"pipeline"')
    end = text.index("\n", start) + 1
    assert text[:start] + text[end:] == golden
