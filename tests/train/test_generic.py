"""train/generic.py makes the shipped generic ball model again, byte for byte, from the
shared set: the file in the package is what the committed script writes, so a change to
the script (its threshold, its pool) cannot ship without the model made again."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SHARED = [ROOT.parent / "shared" / "real" / n for n in ("msl-images", "msl-more")]


@pytest.mark.skipif(not all(p.is_dir() for p in SHARED), reason="the shared set is not here")
def test_the_shipped_generic_model_is_what_the_script_writes(tmp_path: Path) -> None:
    out = tmp_path / "generic.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "train" / "generic.py"), *map(str, SHARED),
         "--groups", str(ROOT / "train" / "msl-events.txt"), "-o", str(out)],
        capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    shipped = ROOT / "estimator" / "detection" / "real" / "ball_generic.json"
    assert out.read_bytes() == shipped.read_bytes()
