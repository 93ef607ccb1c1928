"""The one atomic-output helper: an output file appears whole or not at all.

:class:`AtomicFile` for writers that live across calls (a sink commits when a replay ends);
:func:`atomic_output` for a block that writes a file in one go. Both

- refuse an output that is a folder or whose folder is missing, and an existing output unless
  ``force`` (:func:`check_output_path`);
- create the temporary file beside the output exclusively (``O_CREAT | O_EXCL``, and
  ``O_NOFOLLOW`` where the system has it): a file or symlink planted at the temporary name is
  never opened, written through or replaced; another name is taken instead;
- fsync the file, rename it onto the output (without ``force`` by a hard link, which fails
  when the output appeared meanwhile, so nothing is clobbered) and fsync the folder;
- turn a failing write (full disk, read-only or missing folder) into one
  :class:`~dsp.errors.OutputError` naming the output, and leave no temporary file behind.

Temporary names are hidden (``.NAME.<host>-<pid>-<random>.tmp``; the next writer of NAME
removes those a killed process of this machine left) unless a ``partial`` suffix is given:
then they are visible and numbered, ``NAME.partial.mcap``, ``NAME.partial-2.mcap``, ..., so
a log cut short by a crash is easy to find, and one never replaces an earlier one
(:func:`partial_paths` lists them).

:func:`same_file` and :func:`check_distinct` keep outputs off the inputs and off each other.
Every command states which of its options name files it reads and which name files it
writes (:func:`declare_files`, kept on its parser, so :func:`declared_files` and a test can
walk every parser and find an undeclared file option); the command then compares all of
them, with the files it derives (a batch's summaries), before any work.

:func:`stale_temporaries` finds the hidden temporary files a killed run left beside an
output (:func:`remove_stale_temporaries` removes them).
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import re
import secrets
import socket
import zlib
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from dsp.errors import OutputError, OutputExistsError, UsageError

__all__ = [
    "AtomicFile",
    "FileOptions",
    "atomic_output",
    "check_distinct",
    "check_output_path",
    "declare_files",
    "declared_files",
    "named_files",
    "partial_paths",
    "remove_stale_temporaries",
    "same_file",
    "stale_temporaries",
]

_CREATE = (os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
           | getattr(os, "O_CLOEXEC", 0))
_WRITE_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EIO})
_MAX_PARTIALS = 1000


def same_file(a: Path | str, b: Path | str) -> bool:
    """True when ``a`` and ``b`` name one file: the same path once symlinks and ``..`` are
    resolved, or (when both exist) the same device and inode (hard links, bind mounts)."""
    with contextlib.suppress(OSError, RuntimeError):
        if Path(a).resolve() == Path(b).resolve():
            return True
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _keys(path: Path) -> list[object]:
    """What identifies a file: its resolved path and, when it exists, its device and inode."""
    keys: list[object] = []
    try:
        keys.append(path.resolve())
    except (OSError, RuntimeError):
        keys.append(Path(os.path.abspath(path)))
    with contextlib.suppress(OSError, ValueError):
        st = os.stat(path)
        keys.append((st.st_dev, st.st_ino))
    return keys


def check_distinct(outputs: Sequence[tuple[str, Path | str | None]],
                   inputs: Sequence[tuple[str, Path | str | None]] = ()) -> None:
    """Raise :class:`~dsp.errors.UsageError` when an output names an input or another output
    (as :func:`same_file` sees it; linear in the number of paths).

    Each entry is ``(label, path)`` with a label as the user knows it ("--out", "the input
    log"); ``None`` paths are skipped."""
    seen_in: dict[object, tuple[str, Path]] = {}
    for label, p in inputs:
        if p is not None:
            for key in _keys(Path(p)):
                seen_in.setdefault(key, (label, Path(p)))
    seen_out: dict[object, str] = {}
    for label, p in outputs:
        if p is None:
            continue
        out = Path(p)
        keys = _keys(out)
        for key in keys:
            if key in seen_in:
                what, given = seen_in[key]
                if str(given) != str(out) and str(given) not in what:
                    what = f"{what} {given}"  # a link or another spelling: name both
                raise UsageError(f"{label} {out} is {what}; an output never "
                                 "overwrites an input, choose another file")
            if key in seen_out:
                raise UsageError(f"{seen_out[key]} and {label} both name {out}; give each "
                                 "output its own file")
        for key in keys:
            seen_out[key] = label


@dataclass(frozen=True)
class FileOptions:
    """Which options of a command name files: each entry an option string (``--out``) or a
    positional's name (``log``), as the user sees it.

    ``inputs``: files (or folders of files) the command reads; ``outputs``: files it
    writes; ``output_dirs``: folders it writes files into (the command adds what it writes
    there itself); ``names``: words an input option takes in place of a file
    (``--cameras paper``)."""

    inputs: tuple[str, ...] = ()
    outputs: tuple[str, ...] = ()
    output_dirs: tuple[str, ...] = ()
    names: tuple[str, ...] = ()

    @property
    def options(self) -> tuple[str, ...]:
        return self.inputs + self.outputs + self.output_dirs


_DECLARED = "_dsp_file_options"


def _action(parser: argparse.ArgumentParser, option: str) -> argparse.Action:
    for action in parser._actions:
        if option in action.option_strings or (not action.option_strings
                                               and action.dest == option):
            return action
    raise ValueError(f"{parser.prog} has no option {option!r} to declare as a file")


def declare_files(parser: argparse.ArgumentParser, *, inputs: Sequence[str] = (),
                  outputs: Sequence[str] = (), output_dirs: Sequence[str] = (),
                  names: Sequence[str] = ()) -> None:
    """Record on ``parser`` which of its options name files it reads (``inputs``) and
    writes (``outputs``, ``output_dirs``); each must be an option of the parser."""
    files = FileOptions(tuple(inputs), tuple(outputs), tuple(output_dirs), tuple(names))
    for option in files.options:
        _action(parser, option)
    parser.set_defaults(**{_DECLARED: files})


def declared_files(parser: argparse.ArgumentParser) -> FileOptions:
    """What :func:`declare_files` recorded on ``parser`` (nothing when it was not called)."""
    files = parser.get_default(_DECLARED)
    return files if isinstance(files, FileOptions) else FileOptions()


def named_files(parser: argparse.ArgumentParser, args: argparse.Namespace,
                options: Sequence[str]) -> list[tuple[str, Path]]:
    """The files that ``options`` of ``parser`` name in ``args`` (one entry per file of a
    list-valued option; not given, and the words of :attr:`FileOptions.names`, left out),
    each labelled as the user knows it ("--ball", "the input log")."""
    words = declared_files(parser).names
    found: list[tuple[str, Path]] = []
    for option in options:
        action = _action(parser, option)
        value = getattr(args, action.dest, None)
        values = value if isinstance(value, (list, tuple)) else [value]
        label = option if action.option_strings else f"the input {option}"
        for v in values:
            if isinstance(v, (str, os.PathLike)) and str(v) not in words:
                found.append((label, Path(v)))
    return found


def check_output_path(path: Path | str, *, force: bool, label: str | None = None) -> None:
    """Refuse an output that is a folder, whose folder is missing or not a folder, or that
    exists already (unless ``force``); ``label`` (e.g. "--out") prefixes the message."""
    path = Path(path)
    name = f"{label} {path}" if label else str(path)
    if path.is_dir():
        raise UsageError(f"{name}: is a folder; give a file name")
    parent = path.parent
    if not parent.is_dir():
        what = "is not a folder" if parent.exists() else "does not exist"
        raise UsageError(f"{name}: folder {parent} {what}; create it first")
    if os.path.lexists(path) and not force:
        raise OutputExistsError(path)


def partial_paths(path: Path | str, suffix: str = ".partial") -> list[Path]:
    """The numbered temporary files beside ``path`` that :class:`AtomicFile` with
    ``partial=suffix`` creates (left by a crash or an interruption), oldest number first."""
    path = Path(path)
    stem, ext = _split(path.name)
    pattern = re.compile(re.escape(stem + suffix) + r"(?:-(\d+))?" + re.escape(ext) + "$")
    found = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(path.parent):
            m = pattern.fullmatch(entry.name)
            if m and entry.is_file(follow_symlinks=False):
                found.append((int(m.group(1) or 1), path.with_name(entry.name)))
    return [p for _, p in sorted(found)]


def _split(name: str) -> tuple[str, str]:
    stem, dot, ext = name.rpartition(".")
    return (stem, dot + ext) if stem else (name, "")


def _host_tag() -> str:
    """This machine, in 4 hex digits (a temporary name says which host's process made it)."""
    return f"{zlib.crc32(socket.gethostname().encode()) & 0xFFFF:04x}"


def _tmp_pattern(name: str) -> re.Pattern[str]:
    return re.compile(r"\." + re.escape(name) + r"\.([0-9a-f]{4})-(\d+)-[0-9a-f]{8}\.tmp")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True  # another user's process, or not a pid here: leave its file alone
    return True


def stale_temporaries(path: Path | str) -> list[Path]:
    """The hidden temporary files beside ``path`` that a killed run of this machine left:
    their names (``.NAME.<host>-<pid>-<random>.tmp``) name a process that no longer runs.
    A live run's, and another machine's, are not listed."""
    path = Path(path)
    pattern = _tmp_pattern(path.name)
    host = _host_tag()
    found = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(path.parent):
            m = pattern.fullmatch(entry.name)
            if (m and m.group(1) == host and int(m.group(2)) != os.getpid()
                    and not _alive(int(m.group(2)))
                    and entry.is_file(follow_symlinks=False)):
                found.append(path.with_name(entry.name))
    return sorted(found)


def remove_stale_temporaries(path: Path | str) -> list[Path]:
    """Remove :func:`stale_temporaries` of ``path``; returns those removed."""
    removed = []
    for tmp in stale_temporaries(path):
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
            removed.append(tmp)
    return removed


def _fsync_dir(folder: Path) -> None:
    flags = os.O_RDONLY | getattr(os, "O_DIRECTORY", 0)
    try:
        fd = os.open(folder, flags)
    except OSError:  # pragma: no cover - systems that cannot open a folder
        return
    try:
        os.fsync(fd)
    except OSError as err:  # pragma: no cover - file systems without directory fsync
        if err.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EBADF):
            raise
    finally:
        os.close(fd)


class AtomicFile:
    """A new file written under a temporary name beside ``path``: :meth:`commit` renames it
    onto ``path``, :meth:`discard` removes it (a no-op after a commit), :meth:`keep` leaves it
    (fsynced) where it is.

    Raises before anything is written: :class:`~dsp.errors.OutputExistsError` when ``path``
    exists and ``force`` is false, :class:`~dsp.errors.UsageError` when ``path`` is a folder
    or its folder is missing, :class:`~dsp.errors.OutputError` when the folder is not
    writable. The temporary file is created empty with the mode any new file gets; write it
    through :meth:`stream` (the exclusively created descriptor) or by its name :attr:`tmp`.
    """

    def __init__(self, path: Path | str, *, force: bool, partial: str | None = None,
                 label: str | None = None) -> None:
        self.path = Path(path)
        self.force = force
        check_output_path(self.path, force=force, label=label)
        if partial is None:  # what a killed run of this output left (a partial stays visible)
            remove_stale_temporaries(self.path)
        self.tmp, fd = self._create(partial)
        self._fd: int | None = fd
        st = os.fstat(fd)
        self._identity = (st.st_dev, st.st_ino)
        self.done = False

    def _create(self, partial: str | None) -> tuple[Path, int]:
        stem, ext = _split(self.path.name)
        for n in range(1, _MAX_PARTIALS + 1):
            if partial is None:
                name = (f".{self.path.name}.{_host_tag()}-{os.getpid()}-"
                        f"{secrets.token_hex(4)}.tmp")
            else:
                name = f"{stem}{partial}{'' if n == 1 else f'-{n}'}{ext}"
            tmp = self.path.with_name(name)
            try:
                return tmp, os.open(tmp, _CREATE, 0o666)
            except FileExistsError:
                continue
            except OSError as err:
                raise OutputError(self.path, err) from err
        raise OutputError(self.path, f"no free temporary name beside it ({tmp.name} and "
                          f"{_MAX_PARTIALS - 1} more exist)")

    def stream(self) -> IO[bytes]:
        """The temporary file opened for binary writing (only once; the caller closes it)."""
        if self._fd is None:
            raise ValueError(f"the stream of {self.tmp} was taken already")
        fd, self._fd = self._fd, None
        return os.fdopen(fd, "wb")

    @contextlib.contextmanager
    def guard(self) -> Iterator[None]:
        """Turn a failing write of the temporary file (full disk, read-only file system, an
        error naming the temporary file) into an :class:`~dsp.errors.OutputError` naming the
        output."""
        try:
            yield
        except OSError as err:
            if err.errno in _WRITE_ERRNOS or (err.filename is not None
                                              and Path(err.filename) == self.tmp):
                raise OutputError(self.path, err) from err
            raise

    def _close_fd(self) -> None:
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)

    def _sync(self) -> None:
        """fsync the temporary file, after checking it is still the file made for it."""
        self._close_fd()
        fd = os.open(self.tmp, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
        try:
            st = os.fstat(fd)
            if (st.st_dev, st.st_ino) != self._identity:
                raise OutputError(self.path, f"its temporary file {self.tmp.name} was replaced "
                                  "while writing")
            os.fsync(fd)
        finally:
            os.close(fd)

    def commit(self) -> None:
        """fsync, rename onto :attr:`path` (never replacing one that appeared meanwhile
        without ``force``), fsync the folder."""
        with self.guard():
            self._sync()
            if self.force:
                os.replace(self.tmp, self.path)
            else:
                self._link_no_clobber()
            _fsync_dir(self.path.parent)
        self.done = True

    def _link_no_clobber(self) -> None:
        try:
            os.link(self.tmp, self.path, follow_symlinks=False)
        except FileExistsError:
            raise OutputExistsError(self.path) from None
        except OSError:  # a file system without hard links: check, then rename
            if os.path.lexists(self.path):
                raise OutputExistsError(self.path) from None
            os.replace(self.tmp, self.path)
        else:
            os.unlink(self.tmp)

    def keep(self) -> Path:
        """Leave the temporary file where it is (fsynced) and return its path."""
        with self.guard():
            self._sync()
            _fsync_dir(self.path.parent)
        self.done = True
        return self.tmp

    def discard(self) -> None:
        """Remove the temporary file (a no-op after :meth:`commit` or :meth:`keep`)."""
        self._close_fd()
        if not self.done:
            self.tmp.unlink(missing_ok=True)
            self.done = True


@contextlib.contextmanager
def atomic_output(path: Path | str, *, force: bool, label: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` when the block
    succeeds, remove it otherwise (also on Ctrl-C). Refuses as :class:`AtomicFile` does; a
    failing write in the block becomes an :class:`~dsp.errors.OutputError`."""
    out = AtomicFile(path, force=force, label=label)
    try:
        with out.guard():
            yield out.tmp
        out.commit()
    finally:
        out.discard()
