"""dsp.atomic.atomic_output: a file appears whole on success, nothing is left on failure, and
an existing file is refused without force."""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path
from typing import Any

import pytest

from dsp import atomic
from dsp.atomic import AtomicFile, atomic_output, check_distinct, partial_paths, same_file
from dsp.errors import EXIT_OUTPUT_EXISTS, OutputError, OutputExistsError, UsageError


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


# --- exclusive temporary files, fsync, refusals -------------------------------------------


def test_a_planted_symlink_at_the_temporary_name_is_never_followed(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.write_text("precious")
    target = tmp_path / "run.mcap"
    planted = tmp_path / "run.partial.mcap"
    planted.symlink_to(victim)
    out = AtomicFile(target, force=False, partial=".partial")
    assert out.tmp == tmp_path / "run.partial-2.mcap"  # the planted name is skipped
    with out.stream() as f:
        f.write(b"log")
    out.commit()
    assert target.read_bytes() == b"log" and victim.read_text() == "precious"
    assert planted.is_symlink() and not out.tmp.exists()


def test_hidden_temporary_names_are_created_exclusively(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    names = iter(["aaaa", "aaaa", "bbbb"])
    monkeypatch.setattr(atomic.secrets, "token_hex", lambda n: next(names))
    prefix = f".r.json.{atomic._host_tag()}-{os.getpid()}-"
    (tmp_path / f"{prefix}aaaa.tmp").symlink_to(tmp_path / "elsewhere")
    out = AtomicFile(tmp_path / "r.json", force=False)
    assert out.tmp.name == f"{prefix}bbbb.tmp"
    assert not (tmp_path / "elsewhere").exists()
    out.discard()


def test_partial_names_are_numbered_and_listed(tmp_path: Path) -> None:
    target = tmp_path / "run.mcap"
    kept = []
    for _ in range(3):
        out = AtomicFile(target, force=False, partial=".partial")
        kept.append(out.keep())
    assert [p.name for p in kept] == ["run.partial.mcap", "run.partial-2.mcap",
                                      "run.partial-3.mcap"]
    assert partial_paths(target) == kept
    assert partial_paths(tmp_path / "other.mcap") == []


def test_file_and_folder_are_fsynced_before_the_rename_is_done(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    synced: list[str] = []
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        synced.append("dir" if stat.S_ISDIR(os.fstat(fd).st_mode) else "file")
        real_fsync(fd)

    monkeypatch.setattr(atomic.os, "fsync", fsync)
    with atomic_output(tmp_path / "out.json", force=False) as tmp:
        tmp.write_text("x")
        assert synced == []
    assert synced == ["file", "dir"]


def test_an_output_appearing_meanwhile_is_not_clobbered(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    out = AtomicFile(target, force=False)
    target.write_text("someone else's")
    with pytest.raises(OutputExistsError):
        out.commit()
    out.discard()
    assert target.read_text() == "someone else's"
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_a_replaced_temporary_file_is_refused(tmp_path: Path) -> None:
    out = AtomicFile(tmp_path / "out.json", force=False)
    out.tmp.unlink()
    out.tmp.write_text("swapped in")
    with pytest.raises(OutputError, match="was replaced while writing"):
        out.commit()
    out.discard()
    assert not (tmp_path / "out.json").exists()


@pytest.mark.parametrize(("make", "match"), [
    (lambda p: p.mkdir(), r"out\.json: is a folder; give a file name"),
    (lambda p: None, r"folder .*missing does not exist; create it first"),
])
def test_folder_and_missing_folder_are_one_line_refusals(tmp_path: Path, make: Any,
                                                         match: str) -> None:
    target = tmp_path / "out.json"
    make(target)
    if "missing" in match:
        target = tmp_path / "missing" / "out.json"
    with pytest.raises(UsageError, match=match):
        AtomicFile(target, force=True)
    assert not list(tmp_path.glob("**/*.tmp")) and not list(tmp_path.glob("**/.*"))


@pytest.mark.parametrize("code", [errno.EACCES, errno.EROFS, errno.ENOSPC])
def test_an_unwritable_folder_is_one_error_naming_the_output(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, code: int) -> None:
    def refuse(path: Any, flags: int, mode: int = 0o777) -> int:
        raise OSError(code, os.strerror(code), str(path))

    monkeypatch.setattr(atomic.os, "open", refuse)
    with pytest.raises(OutputError) as info:
        AtomicFile(tmp_path / "out.json", force=False)
    assert str(info.value) == f"{tmp_path / 'out.json'}: cannot write: {os.strerror(code)}"
    assert ".tmp" not in str(info.value)


def test_a_full_disk_while_writing_is_one_error_and_leaves_nothing(tmp_path: Path) -> None:
    target = tmp_path / "out.json"
    with pytest.raises(OutputError, match=r"out\.json: cannot write: No space left"), \
            atomic_output(target, force=False) as tmp:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp))
    assert list(tmp_path.iterdir()) == []


def test_other_errors_in_the_block_pass_through(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError), atomic_output(tmp_path / "o.json", force=False):
        (tmp_path / "no-such-input").read_text()
    assert list(tmp_path.iterdir()) == []


def test_same_file_sees_symlinks_hard_links_and_dotdot(tmp_path: Path) -> None:
    a = tmp_path / "a.json"
    a.write_text("x")
    (tmp_path / "sym.json").symlink_to(a)
    os.link(a, tmp_path / "hard.json")
    (tmp_path / "sub").mkdir()
    assert same_file(a, tmp_path / "sym.json")
    assert same_file(a, tmp_path / "hard.json")
    assert same_file(a, tmp_path / "sub" / ".." / "a.json")
    assert same_file(tmp_path / "new.json", tmp_path / "sub" / ".." / "new.json")
    assert not same_file(a, tmp_path / "b.json")


def test_check_distinct_names_both_sides(tmp_path: Path) -> None:
    log = tmp_path / "in.mcap"
    log.write_bytes(b"x")
    with pytest.raises(UsageError, match=r"--out-mcap .*in\.mcap is the input log"):
        check_distinct([("--out-mcap", log)], [("the input log", log)])
    with pytest.raises(UsageError, match=r"--out and --save both name"):
        check_distinct([("--out", tmp_path / "r.json"), ("--save", tmp_path / "r.json")])
    check_distinct([("--out", tmp_path / "r.json"), ("--save", None)], [("log", None)])


def _dead_pid() -> int:
    """A process id that ran and has ended (its parent reaped it)."""
    import subprocess
    import sys

    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_the_next_writer_removes_what_a_killed_run_left(tmp_path: Path) -> None:
    host = atomic._host_tag()
    dead = tmp_path / f".r.json.{host}-{_dead_pid()}-0123abcd.tmp"
    dead.write_text("half a results file")
    live = tmp_path / f".r.json.{host}-{os.getppid()}-0123abcd.tmp"  # a running process
    live.write_text("still being written")
    elsewhere = tmp_path / f".r.json.{(int(host, 16) + 1) % 0x10000:04x}-{_dead_pid()}-0123abcd.tmp"
    elsewhere.write_text("another machine's run")
    other = tmp_path / f".s.json.{host}-{_dead_pid()}-0123abcd.tmp"
    other.write_text("another output's")
    assert atomic.stale_temporaries(tmp_path / "r.json") == [dead]
    with atomic_output(tmp_path / "r.json", force=False) as tmp:
        tmp.write_text("{}")
    assert not dead.exists()
    assert live.exists() and elsewhere.exists() and other.exists()
    assert (tmp_path / "r.json").read_text() == "{}"


def test_declared_files_are_named_from_the_arguments(tmp_path: Path) -> None:
    import argparse

    p = argparse.ArgumentParser()
    p.add_argument("log", type=Path, nargs="+")
    p.add_argument("--cameras")
    p.add_argument("--out", type=Path)
    atomic.declare_files(p, inputs=("log", "--cameras"), outputs=("--out",), names=("paper",))
    args = p.parse_args(["a.mcap", "b.mcap", "--cameras", "paper", "--out", "r.json"])
    files = atomic.declared_files(p)
    assert atomic.named_files(p, args, files.inputs) == [("the input log", Path("a.mcap")),
                                                        ("the input log", Path("b.mcap"))]
    assert atomic.named_files(p, args, files.outputs) == [("--out", Path("r.json"))]
    with pytest.raises(ValueError, match="--nothing"):
        atomic.declare_files(p, inputs=("--nothing",))


def test_a_clash_through_a_link_names_both_paths(tmp_path: Path) -> None:
    ball = tmp_path / "ball.json"
    ball.write_text("{}")
    link = tmp_path / "link.json"
    link.symlink_to(ball)
    with pytest.raises(UsageError, match=r"^--out .*link\.json is the --ball file .*ball\.json;"):
        check_distinct([("--out", link)], [("the --ball file", ball)])
