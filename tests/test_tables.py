"""The accuracy and speed tables of the README and the site are what scripts/make_tables.py
writes: the accuracy figures the goldens', the speed row and the stamp in the script's form
(their values are measured, so only their form is checked)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def tables() -> ModuleType:
    spec = importlib.util.spec_from_file_location("make_tables", ROOT / "scripts" /
                                                  "make_tables.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["make_tables"] = module
    spec.loader.exec_module(module)
    return module


def test_the_committed_tables_are_the_scripts(tables: ModuleType) -> None:
    assert tables.problems() == []


def test_a_typed_figure_or_a_changed_form_is_caught(tables: ModuleType) -> None:
    block = tables.readme_block(tables.README.read_text(encoding="utf-8"))
    pattern = tables.headline_pattern()
    assert pattern.fullmatch(block)
    first = tables.accuracy_rows()[0]
    typed = block.replace(f"| {first[2]} |", "| 0.300 m |", 1)
    assert typed != block and not pattern.fullmatch(typed)
    assert not pattern.fullmatch(block.replace("frames/s", "fps"))
    assert not pattern.fullmatch(block.replace(" at the start.", " at the start, idle."))
    speed = next(line for line in block.splitlines() if line.endswith("frames/s |"))
    faster = block.replace(speed, speed.rsplit("|", 2)[0] + "| 99999 frames/s |")
    assert pattern.fullmatch(faster)  # a new measurement is a new value, the same form


def test_the_accuracy_rows_pool_the_goldens(tables: ModuleType) -> None:
    scenes = ("scenario1", "scenario2", "scenario3", "scenario4")
    rmse, steps = tables.pooled_rmse_m(scenes, "paper-mean")
    assert steps == 12
    single = [tables.pooled_rmse_m((s,), "paper-mean")[0] for s in scenes]
    assert min(single) <= rmse <= max(single)
    assert tables.accuracy_rows()[0][3] == f"{rmse:.3f} m"  # after frames and the default
