"""scripts/lookup_cameras.py: a log's cameras as lookup tables alone, the same ranges."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from replay.cameras import cameras_for
from replay.log import LogReader

ROOT = Path(__file__).resolve().parents[2]
LOG = ROOT / "logs" / "golden" / "match.mcap"


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(ROOT / "scripts" / "lookup_cameras.py"), *args],
                          cwd=cwd, capture_output=True, text=True, timeout=120, check=False)


def _cameras(log: Path, cameras: Path | None = None):  # type: ignore[no-untyped-def]
    with LogReader(log) as reader:
        info = reader.info
        return info.robots, cameras_for(info.robots, log=str(log),
                                        metadata=info.cameras.camera_set(), cameras=cameras)


def test_every_robot_becomes_a_table_with_its_own_ranges(tmp_path: Path) -> None:
    out = tmp_path / "lookup.yaml"
    run = _run(str(LOG), str(out), cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    robots, before = _cameras(LOG)
    _, after = _cameras(LOG, out)
    assert before.models and not after.models  # the models are gone: a table alone
    for robot in robots:
        assert after.sources is not None and after.sources[robot] == str(out)
        assert after.centres[robot] == before.centres[robot]
        r = np.linspace(5.0, 400.0, 37)
        want = np.array([before.calibrations[robot].range_m(float(x)) for x in r])
        got = np.array([after.calibrations[robot].range_m(float(x)) for x in r])
        assert np.all(np.abs(got - want) <= 2e-3 * np.maximum(want, 1.0)), robot


@pytest.mark.parametrize(("args", "code", "problem"), [
    (["missing.mcap", "o.yaml"], 1, "missing.mcap"),
    ([str(LOG), "o.txt"], 2, "o.txt"),
    ([str(LOG), "o.yaml", "--step-px", "0"], 2, "--step-px"),
])
def test_bad_input_is_one_line(tmp_path: Path, args: list[str], code: int,
                               problem: str) -> None:
    run = _run(*args, cwd=tmp_path)
    lines = run.stderr.strip().splitlines()
    assert run.returncode == code, run.stderr
    assert len(lines) == 1 and lines[0].startswith("lookup_cameras.py: error: "), run.stderr
    assert problem in lines[0] and "Traceback" not in run.stderr
    assert not (tmp_path / "o.yaml").exists() and not (tmp_path / "o.txt").exists()
