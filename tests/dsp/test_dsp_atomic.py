"""dsp.atomic.atomic_output: a file appears whole on success, nothing is left on failure, and
an existing file is refused without force."""

from __future__ import annotations

from pathlib import Path

import pytest

from dsp.atomic import atomic_output
from dsp.errors import EXIT_OUTPUT_EXISTS, OutputExistsError


def test_renames_onto_the_target_on_success(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    with atomic_output(target, force=False) as tmp:
        assert tmp.parent == tmp_path and tmp != target
        tmp.write_text("done")
        assert not target.exists()  # nothing at the target until the block succeeds
    assert target.read_text() == "done"
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_gets_the_mode_a_new_file_gets(tmp_path: Path) -> None:
    plain = tmp_path / "plain"
    plain.write_text("x")
    with atomic_output(tmp_path / "atomic", force=False) as tmp:
        tmp.write_text("x")
    assert (tmp_path / "atomic").stat().st_mode == plain.stat().st_mode


@pytest.mark.parametrize("exc", [RuntimeError("boom"), KeyboardInterrupt()])
def test_leaves_nothing_on_failure(tmp_path: Path, exc: BaseException) -> None:
    target = tmp_path / "out.json"
    with pytest.raises(type(exc)), atomic_output(target, force=False) as tmp:
        tmp.write_text("half")
        raise exc
    assert list(tmp_path.iterdir()) == []


def test_a_failed_forced_write_keeps_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_output(target, force=True) as tmp:
        tmp.write_text("new")
        raise RuntimeError
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_refuses_an_existing_target_without_force(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")
    entered = False
    with pytest.raises(OutputExistsError, match=r"out\.json: output exists already \(use --force"
                       ) as info, atomic_output(target, force=False):
        entered = True
    assert not entered and info.value.exit_code == EXIT_OUTPUT_EXISTS == 3
    assert info.value.path == target
    assert target.read_text() == "old" and len(list(tmp_path.iterdir())) == 1


def test_force_overwrites(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")
    with atomic_output(str(target), force=True) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]
