"""An empty selection (--start past the end, --end before the start, no robot, no image in
the window) is an error in one line, not a table of zeros with exit 0."""

from __future__ import annotations

from pathlib import Path

import pytest

from replay.cli import main

ROLLING = Path(__file__).resolve().parents[2] / "logs" / "golden" / "rolling.mcap"


@pytest.mark.parametrize(("argv", "needle"), [
    (["--start", "20"], "--start 20 s is past the end of"),
    (["--end", "-1"], "--end -1 s is before the start of"),
    (["--robots", ","], "--robots names no robot"),
    (["--start", "1.2", "--end", "1.3"], "lies between 1.2 s and 1.3 s"),
])
def test_an_empty_selection_is_an_error(argv: list[str], needle: str, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.json"
    assert main([str(ROLLING), *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err, err
    assert "0.000 to 1.750 s" in err or "--robots" in err
    assert not out.exists()


def test_a_window_with_images_replays(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(ROLLING), "--start", "0.4", "--end", "1.1"]) == 0
    assert "replayed rolling.mcap: 6 frames" in capsys.readouterr().out
