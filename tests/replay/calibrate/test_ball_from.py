"""dsp-calibrate --ball-from DIR writes a ball model that dsp-replay --ball reads: the same
images give the same bytes, bad labels and bad model files are one line naming the file,
and a replay with the real detector records it in its results and is the same bytes
whatever the thread count."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from dsp.ball_file import read_ball_file
from dsp.errors import InputError, UsageError
from estimator.detection.real.head import HEAD_THRESHOLD
from replay import ReplayOptions, replay
from replay.calibrate.cli import main
from replay.profiles import options_for

ROOT = Path(__file__).resolve().parents[3]
SUBSET = ROOT / "tests" / "data" / "msl-images" / "20220715" / "r7"
GOLDEN = ROOT / "logs" / "golden"


def _run(argv: list[object], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def ball_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ball") / "ball.json"
    assert main(["--ball-from", str(SUBSET), "--train-count", "10", "-o", str(out), "-q"]) == 0
    return out


def test_the_model_is_fitted_from_the_first_images_and_is_the_same_bytes(
        ball_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = json.loads(ball_file.read_text())
    assert data["fit"]["images"] == 10 and data["fit"]["first"] == "cam0_20220715_171102.jpg"
    assert data["check_head"] is not None and len(data["check_head"]) == 40
    again = tmp_path / "again.json"
    code, out, _ = _run(["--ball-from", SUBSET, "--train-count", 10, "-o", again], capsys)
    assert code == 0 and "ball model from 10 images" in out and "12 balls" in out
    assert again.read_bytes() == ball_file.read_bytes()
    assert read_ball_file(ball_file).check_head is not None


def test_no_head_and_all_images(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "b.json"
    code, text, _ = _run(["--ball-from", SUBSET, "--no-head", "-o", out], capsys)
    assert code == 0 and "from 14 images" in text and "no venue head" in text
    assert json.loads(out.read_text())["check_head"] is None


@pytest.mark.parametrize(("label", "words"), [
    ("0 0.5 0.5 0.1\n", ":1: not 'class cx cy w h'"),
    ("0 0.5 0.5 1.5 0.1\n", ":1: cx cy w h must be numbers 0-1"),
    ("0 0.5 0.5 0.1 0.1\nball 0.5 0.5 0.1 0.1\n", ":2: not 'class cx cy w h'"),
])
def test_a_bad_label_line_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                   label: str, words: str) -> None:
    folder = tmp_path / "venue"
    folder.mkdir()
    first = sorted(SUBSET.glob("*.jpg"))[0]
    shutil.copy(first, folder / first.name)
    (folder / first.with_suffix(".txt").name).write_text(label)
    out = tmp_path / "b.json"
    code, _, err = _run(["--ball-from", folder, "--no-head", "-o", out], capsys)
    assert code != 0 and not out.exists()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and first.stem + ".txt" + words in lines[0]


def test_no_labels_no_ball_and_bad_counts(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "b.json"
    code, _, err = _run(["--ball-from", tmp_path, "-o", out], capsys)
    assert code != 0 and "no image with a YOLO label file" in err
    folder = tmp_path / "empty-labels"
    folder.mkdir()
    first = sorted(SUBSET.glob("*.jpg"))[0]
    shutil.copy(first, folder / first.name)
    (folder / first.with_suffix(".txt").name).write_text("2 0.5 0.5 0.1 0.1\n")
    code, _, err = _run(["--ball-from", folder, "-o", out], capsys)
    assert code != 0 and "no labelled ball pixels" in err and str(folder) in err
    code, _, err = _run(["--ball-from", SUBSET, "--train-count", 0, "-o", out], capsys)
    assert code != 0 and "--train-count 0" in err
    code, _, err = _run(["--train-count", 3, "-o", out], capsys)
    assert code != 0 and "go with --ball-from" in err
    assert not out.exists()


def test_a_bad_ball_file_is_one_line_naming_it(ball_file: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(InputError, match=r"bad.json: not JSON"):
        read_ball_file(bad)
    data = json.loads(ball_file.read_text())
    data["threshold"] = 3
    bad.write_text(json.dumps(data))
    with pytest.raises(InputError, match=r"bad.json: threshold 3.0 is not a probability"):
        read_ball_file(bad)
    with pytest.raises(InputError, match="is a folder; give a ball model file"):
        read_ball_file(tmp_path)
    with pytest.raises(InputError, match="not a regular file"):
        read_ball_file(Path("/dev/zero"))
    bad.write_bytes(b" " * (2 << 20))
    with pytest.raises(InputError, match="at most"):
        read_ball_file(bad)


def test_the_real_detector_with_no_ball_model_takes_the_generic_one(tmp_path: Path) -> None:
    """--detector real with no --ball: the generic model (a camera file's, when it names
    one), said in the pipeline and recorded in the results."""
    out = tmp_path / "r.json"
    replay(GOLDEN / "match.mcap", options_for(detector="real", out=out, progress=False,
                                              quiet=True, threads=1))
    doc = json.loads(out.read_text())
    assert doc["pipeline"]["detector"] == "real"
    assert doc["pipeline"]["detector_choice"] == ("--detector real with no --ball: the "
                                                  "generic ball model")
    assert doc["options"]["ball"].endswith("ball_generic.json")


def test_a_ball_model_goes_with_the_real_detector() -> None:
    with pytest.raises(UsageError, match="--ball goes with the real detector"):
        ReplayOptions(detector="paper", ball=Path("ball.json"))
    assert ReplayOptions(ball=Path("b.json")).detector_name == "real"
    assert ReplayOptions().detector_name == "paper"


def test_a_replay_with_the_real_detector_records_it_and_is_the_same_bytes(
        ball_file: Path, tmp_path: Path) -> None:
    log = GOLDEN / "match.mcap"
    outs = []
    for threads in (1, 2):
        out = tmp_path / f"r{threads}.json"
        replay(log, ReplayOptions(detector="real", ball=ball_file, out=out, threads=threads,
                                  progress=False, quiet=True))
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
    options = json.loads(outs[0])["options"]
    assert options["detector"] == "real" and options["ball"] == "ball.json"
    paper = tmp_path / "paper.json"
    replay(log, ReplayOptions(out=paper, progress=False, quiet=True))
    assert "detector" not in json.loads(paper.read_text())["options"]


def test_an_image_that_does_not_decode_is_named(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "venue"
    folder.mkdir()
    (folder / "a.jpg").write_bytes(b"\xff\xd8 not really a JPEG" * 10)
    (folder / "a.txt").write_text("0 0.5 0.5 0.1 0.1\n")
    out = tmp_path / "b.json"
    code, _, err = _run(["--ball-from", folder, "-o", out], capsys)
    assert code != 0 and not out.exists()
    assert err.strip().splitlines() == [f"dsp-calibrate: error: {folder / 'a.jpg'}: not a "
                                        "readable JPEG or PNG image"]


def test_ball_generic_writes_the_shipped_generic_model(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--ball-generic: no frame of the venue, the package's generic model (no venue head,
    fitted on every event of the shared set), which dsp-replay --ball reads; it fits
    nothing, so --ball-from and --train-count are refused beside it."""
    out = tmp_path / "generic.json"
    code, text, _ = _run(["--ball-generic", "-o", out], capsys)
    assert code == 0 and "generic ball model from" in text and "of 8 events" in text
    model = read_ball_file(out)
    assert model.check_head is None and model.threshold == HEAD_THRESHOLD  # logit 1
    assert model.fit["generic"] is True and len(model.fit["events"]) == 8
    assert out.read_bytes() == (ROOT / "estimator" / "detection" / "real"
                                / "ball_generic.json").read_bytes()
    code, _, err = _run(["--ball-generic", "--ball-from", SUBSET, "-o", out, "--force"],
                        capsys)
    assert code == 2 and "--ball-generic fits nothing" in err


@pytest.mark.parametrize("mode", [["--ball-generic"], ["--ball-from", SUBSET]])
def test_a_ball_model_has_no_figure_so_plot_is_refused(
        mode: list[object], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out, plot = tmp_path / "ball.json", tmp_path / "b.png"
    code, _, err = _run([*mode, "-o", out, "--plot", plot], capsys)
    assert code == 2 and len(err.splitlines()) == 1
    assert err.startswith(f"dsp-calibrate: error: --plot draws a camera calibration; {mode[0]} "
                          "writes a ball model, which has no figure (leave --plot out)")
    assert list(tmp_path.iterdir()) == []
