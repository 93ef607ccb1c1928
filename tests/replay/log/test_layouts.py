"""Every valid MCAP layout replays as the recorder's own: the golden rolling log rewritten
by the mcap library (chunked or not, each compression, small chunks, without statistics,
summary offsets, CRCs, indexes, repeated channels or schemas) gives the same results file,
byte for byte but for the log's name and hash."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from fuzzing import GOLDEN, read_raw, write_raw
from mcap.writer import CompressionType, IndexType

from replay.options import ReplayOptions
from replay.runner import replay

LAYOUTS: dict[str, dict[str, Any]] = {
    "recorder": {"compression": CompressionType.ZSTD, "chunk_size": 4 << 20},
    "unchunked": {"use_chunking": False},
    "uncompressed": {"compression": CompressionType.NONE},
    "lz4-4k": {"compression": CompressionType.LZ4, "chunk_size": 4096},
    "zstd-64k": {"compression": CompressionType.ZSTD, "chunk_size": 64 << 10},
    "no-statistics": {"use_statistics": False},
    "no-summary-offsets": {"use_summary_offsets": False},
    "no-crcs": {"enable_crcs": False},
    "data-crcs": {"enable_data_crcs": True},
    "not-repeated": {"repeat_channels": False, "repeat_schemas": False},
    "no-indexes": {"index_types": IndexType.NONE},
    "bare": {"index_types": IndexType.NONE, "repeat_channels": False,
             "repeat_schemas": False, "use_statistics": False, "use_summary_offsets": False,
             "enable_crcs": False},
    "unchunked-bare": {"use_chunking": False, "index_types": IndexType.NONE,
                       "repeat_channels": False, "repeat_schemas": False,
                       "use_statistics": False},
}


def _results(path: Path, out: Path) -> str:
    replay(path, ReplayOptions(out=out, force=True))
    doc = json.loads(out.read_text())
    doc["log"].pop("file")
    doc["log"].pop("sha256")
    return json.dumps(doc, indent=1, sort_keys=True)


@pytest.fixture(scope="module")
def recorder_results(tmp_path_factory: pytest.TempPathFactory) -> str:
    tmp = tmp_path_factory.mktemp("layouts")
    return _results(GOLDEN / "rolling.mcap", tmp / "golden.json")


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
def test_layout_replays_as_the_recorder_log(layout: str, tmp_path: Path,
                                            recorder_results: str) -> None:
    log = tmp_path / f"{layout}.mcap"
    log.write_bytes(write_raw(read_raw(GOLDEN / "rolling.mcap"), **LAYOUTS[layout]))
    assert _results(log, tmp_path / "r.json") == recorder_results
