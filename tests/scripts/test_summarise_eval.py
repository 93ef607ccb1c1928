"""scripts/summarise_eval.py: the README's cross-camera table from dsp-eval outputs."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("summarise_eval",
                                               ROOT / "scripts" / "summarise_eval.py")
assert _spec is not None and _spec.loader is not None
summarise_eval = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(summarise_eval)

FUSIONS = ("mean", "nearest", "weighted", "robust")


def _write(path: Path, doc: dict) -> None:  # type: ignore[type-arg]
    path.write_text(json.dumps(doc))


def test_one_row_per_camera_with_the_largest_random_suite(tmp_path: Path) -> None:
    d = tmp_path / "mirror"
    d.mkdir()
    _write(tmp_path / "cal-mirror.json", {"model": "mirror", "holdout_rms_m": 0.0106})
    configs = {"paper/mean": {"rmse_m": 2.3461}}
    configs.update({f"corrected/{f}": {"rmse_m": 0.001 * (i + 1)} for i, f in enumerate(FUSIONS)})
    _write(d / "paper-mirror.json", {"camera": "mirror", "calibration": "cal-mirror.json",
                                     "configs": configs})
    for count, rmse in ((200, 0.5), (330, 0.0135)):
        fused = {f"corrected/{f}": {"rmse_m": rmse, "p95_m": 0.03, "max_m": 0.07,
                                    "scenes": count // 2 - 2} for f in FUSIONS}
        _write(d / f"random-mirror-{count}-seed1.json",
               {"count": count, "seed": 1, "dual_sight_scenes": count // 2, "fused": fused})
    table = summarise_eval.summarise([d]).splitlines()
    assert len(table) == 3
    assert table[2] == ("| mirror | mirror (0.0106 m) | 2.3461 | 0.0010 / 0.0020 / 0.0030 / "
                        "0.0040 | 165 of 330 (seed 1); 163 fused | 0.0135 / 0.0135 / 0.0135 "
                        "/ 0.0135 | 0.0300 / 0.0700 |")


def test_a_missing_folder_is_one_line(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    assert summarise_eval.main([str(tmp_path / "nowhere")]) == 2
    assert capsys.readouterr().err.strip().endswith("not a folder: " + str(tmp_path / "nowhere"))
