"""A flush to an .rrd waits while the file grows and gives up once it stops growing, so a
writer stopped by a full disk or a size limit ends the command within seconds."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from replay.sinks.rerun.streams import FLUSH_STALLS, FLUSH_STEP_S, FLUSH_TIMEOUT_S, flush


class Writer:
    """A recording whose flush times out ``slow`` times, adding ``grow`` bytes to ``path``
    each time, then finishes."""

    def __init__(self, path: Path, *, slow: int, grow: int, error: str = "Flush timed out"):
        self.path, self.slow, self.grow, self.error = path, slow, grow, error
        self.timeouts: list[float] = []

    def flush(self, timeout_sec: float) -> None:
        self.timeouts.append(timeout_sec)
        if len(self.timeouts) > self.slow:
            return
        if self.grow:
            with self.path.open("ab") as f:
                f.write(b"x" * self.grow)
        raise RuntimeError(self.error)


def test_a_growing_file_is_waited_for_until_the_flush_ends(tmp_path: Path) -> None:
    rec: Any = Writer(tmp_path / "r.rrd", slow=40, grow=10)
    flush(rec, rec.path)
    assert rec.timeouts == [FLUSH_STEP_S] * 41


def test_a_file_that_stops_growing_is_given_up_after_a_few_steps(tmp_path: Path) -> None:
    rec: Any = Writer(tmp_path / "r.rrd", slow=1000, grow=0)
    rec.path.write_bytes(b"header")
    with pytest.raises(RuntimeError, match="timed out"):
        flush(rec, rec.path)
    assert len(rec.timeouts) == FLUSH_STALLS + 1
    assert FLUSH_STEP_S * (FLUSH_STALLS + 1) <= 3.0


def test_a_writer_error_is_raised_at_once(tmp_path: Path) -> None:
    rec: Any = Writer(tmp_path / "r.rrd", slow=1000, grow=5,
                      error="File-writer thread shut down prematurely")
    with pytest.raises(RuntimeError, match="prematurely"):
        flush(rec, rec.path)
    assert len(rec.timeouts) == 1


def test_a_missing_file_is_a_failed_flush(tmp_path: Path) -> None:
    rec: Any = Writer(tmp_path / "r.rrd", slow=1000, grow=0)
    rec.path = tmp_path / "gone" / "r.rrd"
    with pytest.raises(RuntimeError, match="timed out"):
        flush(rec, rec.path)
    assert len(rec.timeouts) == 1


def test_a_viewer_is_flushed_once_with_the_long_timeout(tmp_path: Path) -> None:
    rec: Any = Writer(tmp_path / "r.rrd", slow=0, grow=0)
    flush(rec, None)
    assert rec.timeouts == [FLUSH_TIMEOUT_S]
