"""dsp-replay --out-csv and --plot: the estimates as CSV with stable columns, a figure of the
replay; both the same bytes for the same log and options; wrong extensions refused."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import pytest

from dsp.errors import UsageError
from dsp.progress import LineProgress
from replay.cli import main as replay_main
from replay.options import ReplayOptions
from replay.runner import replay
from replay.sinks.csv_export import CSV_COLUMNS

GOLDEN = Path(__file__).resolve().parents[3] / "logs" / "golden"


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("exports")
    out = {}
    for run in ("a", "b"):
        out[f"csv_{run}"] = d / f"{run}.csv"
        out[f"png_{run}"] = d / f"{run}.png"
        out[f"json_{run}"] = d / f"{run}.json"
        replay(GOLDEN / "rolling.mcap", ReplayOptions(
            out=out[f"json_{run}"], out_csv=out[f"csv_{run}"], plot=out[f"png_{run}"],
            progress=False))
    return out


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_csv_has_one_row_per_frame_and_step_matching_the_results(exported: dict[str, Path]
                                                                 ) -> None:
    rows = _rows(exported["csv_a"])
    doc = json.loads(exported["json_a"].read_text())
    assert tuple(rows[0]) == CSV_COLUMNS
    frames = [r for r in rows if r["kind"] == "frame"]
    fused = [r for r in rows if r["kind"] == "fused"]
    assert len(frames) == len(doc["frames"]) and len(fused) == len(doc["fused"])
    assert len(rows) == len(frames) + len(fused)
    for row, ref in zip(frames, doc["frames"], strict=True):
        assert (int(row["index"]), row["robot"], row["status"]) == (
            ref["frame"], ref["robot"], ref["status"])
        if ref["estimate"] is None:
            assert row["x_m"] == row["y_m"] == row["error_m"] == ""
        else:
            assert float(row["x_m"]) == ref["estimate"]["x_m"]
            assert float(row["error_m"]) == ref["error_m"]
    for row, ref in zip(fused, doc["fused"], strict=True):
        assert row["robot"] == "fused" and int(row["stamp_ns"]) == ref["stamp_ns"]
        assert float(row["y_m"]) == ref["y_m"]
        assert float(row["cov_xy_m2"]) == ref["covariance"][0][1]
        assert row["robots"].split(";") == ref["fused_robots"]


def test_a_frame_without_a_ball_has_empty_cells_not_zeros(exported: dict[str, Path]) -> None:
    rows = _rows(exported["csv_a"])
    missed = [r for r in rows if r["status"] == "no_detection"]
    assert missed, "the rolling log has frames where robot1 does not see the ball"
    assert all(r["cx_px"] == "" and r["truth_x_m"] != "" for r in missed)
    assert all(math.isfinite(float(r["t_s"])) for r in rows)


def test_exports_are_byte_identical_for_the_same_replay(exported: dict[str, Path]) -> None:
    assert exported["csv_a"].read_bytes() == exported["csv_b"].read_bytes()
    assert exported["png_a"].read_bytes() == exported["png_b"].read_bytes()
    png = exported["png_a"].read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and b"Software" not in png and b"matplotlib" not in png


@pytest.mark.parametrize(("flag", "name", "wanted"), [
    ("--out-csv", "run.json", ".csv"),
    ("--plot", "run.jpg", ".png or .svg"),
    ("--save", "run.mcap", ".rrd"),
    ("--out", "run.csv", ".json"),
    ("--out-mcap", "run.json", ".mcap"),
])
def test_an_output_with_the_wrong_extension_is_refused_before_the_replay(
    flag: str, name: str, wanted: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = replay_main([str(GOLDEN / "rolling.mcap"), flag, str(tmp_path / name)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert f"{flag} " in err and f"must end in {wanted}" in err
    assert not list(tmp_path.iterdir())


def test_two_outputs_naming_one_file_are_refused(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match=r"--out-csv and --plot both name .*x; give each"):
        ReplayOptions(out_csv=tmp_path / "x", plot=tmp_path / "x")


def test_plain_progress_lines_come_every_interval() -> None:
    now = [0.0]
    stream = io.StringIO()
    bar = LineProgress(100, "run.mcap", unit="msg", interval_s=10.0, stream=stream,
                       clock=lambda: now[0])
    for _ in range(100):
        now[0] += 0.25
        bar.update(1)
    lines = stream.getvalue().splitlines()
    assert lines == ["run.mcap: 40/100 msg (40%), 10 s", "run.mcap: 80/100 msg (80%), 20 s"]
