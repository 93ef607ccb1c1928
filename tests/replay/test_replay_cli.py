"""dsp-replay end to end in a subprocess: bad inputs give one line on stderr, a non-zero exit
and no traceback; --recover replays a truncated log; the summary table on stdout."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from synthetic import write_log


def run_cli(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "replay.cli", *map(str, args)],
        capture_output=True, text=True, timeout=120, check=False,
    )


def assert_one_line_error(proc: subprocess.CompletedProcess[str], *needles: str) -> None:
    assert proc.returncode != 0
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    for needle in needles:
        assert needle in lines[0], lines[0]


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("cli")
    good = d / "good.mcap"
    write_log(good, duration_s=1.0, chunk_size=30_000)
    data = good.read_bytes()
    out = {"good": good, "dir": d}
    out["junk"] = d / "junk.mcap"
    out["junk"].write_bytes(b"PK\x03\x04 this is a zip, not a log" * 10)
    out["cut"] = d / "cut.mcap"
    out["cut"].write_bytes(data[: int(len(data) * 0.55)])
    with good.open("rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes  # type: ignore[union-attr]
    middle = chunks[len(chunks) // 2]
    damaged = bytearray(data)
    start = middle.chunk_start_offset + 80
    damaged[start : start + 64] = bytes(64)
    out["corrupt"] = d / "corrupt.mcap"
    out["corrupt"].write_bytes(bytes(damaged))
    out["noposes"] = d / "noposes.mcap"
    write_log(out["noposes"], duration_s=0.2, with_poses=False)
    out["badimages"] = d / "badimages.mcap"
    write_log(out["badimages"], duration_s=0.2, corrupt_images=range(100))
    return out


def test_summary_on_stdout(logs: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    proc = run_cli(logs["good"], "--out", out, "--method", "paper", "--fusion", "robust")
    assert proc.returncode == 0, proc.stderr
    assert "robot1" in proc.stdout and "fused" in proc.stdout and "rmse_m" in proc.stdout
    assert proc.stderr == ""  # no progress bar off a terminal
    assert json.loads(out.read_text())["options"]["fusion"] == "robust"
    again = run_cli(logs["good"], "--out", out)
    assert_one_line_error(again, str(out), "--force")


@pytest.mark.parametrize(
    ("name", "extra", "needles"),
    [
        ("missing", (), ("missing.mcap", "no such file (check the path)")),
        ("dir", (), ("is a folder, not a log",)),
        ("junk", (), ("junk.mcap", "not an MCAP")),
        ("cut", (), ("cut.mcap", "truncated", "--recover")),
        ("corrupt", (), ("corrupt.mcap", "corrupt")),
        ("good", ("--image-topic", "/{robot}/camera/image"), ("good.mcap", "no image topics")),
        ("noposes", (), ("noposes.mcap", "missing poses")),
        ("badimages", (), ("badimages.mcap", "do not decode")),
        ("good", ("--calibration", "nope.json"), ("nope.json", "calibration")),
        ("good", ("--robots", "robot9"), ("robot9",)),
    ],
)
def test_bad_input_is_one_line(
    logs: dict[str, Path], name: str, extra: tuple[str, ...], needles: tuple[str, ...]
) -> None:
    path = logs[name] if name in logs else logs["dir"] / f"{name}.mcap"
    assert_one_line_error(run_cli(path, *extra), *needles)


def test_no_pose_near_any_image_is_missing_poses(tmp_path: Path) -> None:
    log = tmp_path / "late.mcap"
    write_log(log, duration_s=0.5, drop_poses={"robot1": (0.0, 0.5)},
              robots={"robot1": (-3.0, 0.0, 0.0)})
    # only the pose at 0.5 s is left: the images at 0.5 s pass, the others are skipped
    proc = run_cli(log, "--end", "0.35")
    assert_one_line_error(proc, "late.mcap", "missing poses", "within the tolerance")


def test_recover_replays_frames_before_the_cut(logs: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    proc = run_cli(logs["cut"], "--recover", "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert "recovered: lost" in proc.stdout
    doc = json.loads(out.read_text())
    frames = doc["frames"]
    assert 0 < len(frames) < 33
    assert all(f["status"] == "ok" for f in frames[:-3])
    assert doc["log"]["recovered"]["truncated"] is True
    assert doc["log"]["recovered"]["lost_bytes"] > 0
