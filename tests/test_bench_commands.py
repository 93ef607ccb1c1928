"""The benchmarks' child commands are ones the project's commands accept: a benchmark whose
command a CLI change broke fails here, not on the next person who runs it."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

from replay import cli as replay_cli

ROOT = Path(__file__).resolve().parents[1]


def _bench_batch() -> ModuleType:
    spec = importlib.util.spec_from_file_location("bench_batch", ROOT / "benchmarks" /
                                                  "bench_batch.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_batch_benchmark_s_replay_commands_parse(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    bench = _bench_batch()
    ran: list[list[str]] = []

    def run(cmd: list[str], env: dict[str, str], kind: str = "") -> float:
        ran.append(cmd)
        Path(cmd[cmd.index("--out-dir") + 1]).mkdir()
        return 1.0

    monkeypatch.setattr(bench, "_run", run)
    bench.bench_replay(tmp_path, tmp_path / "logs", 2, 1, None)
    assert len(ran) == 2  # --workers 1 and --workers 2
    for cmd in ran:
        assert cmd[:3] == [sys.executable, "-m", "replay.cli"]
        args = replay_cli.build_parser().parse_args(cmd[3:])  # exits 2 on a bad option
        assert str(args.out_dir) == cmd[cmd.index("--out-dir") + 1] and args.estimates
