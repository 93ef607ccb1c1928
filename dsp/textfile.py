"""Small input files (camera files, measurements, images, ball checks) read whole, but
bounded and checked first.

:func:`read_text_file` (and :func:`read_bytes_file`, without the decoding) refuses, each
in one line naming the file: a path that is not a regular file (opened without blocking and
checked on the open descriptor, so neither a FIFO nor a device such as ``/dev/zero`` is
read), a file over ``max_bytes`` (by its size and by what is read, should it grow
meanwhile), and bytes that are not UTF-8 (a leading byte-order mark is dropped). The error
is the caller's class, so each input keeps its own name in the error tree.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path

from dsp.errors import InputError

__all__ = ["TEXT_ERRORS", "read_bytes_file", "read_text_file"]

TEXT_ERRORS = "backslashreplace"
"""How every text file a command writes encodes what UTF-8 cannot hold: a file name that is
not UTF-8 (``bad\\xff.mcap`` reaches Python as a lone surrogate) is written as its escape,
``bad\\udcff.mcap``, as the terminal shows it, instead of failing the write."""

_OPEN = (os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
         | getattr(os, "O_CLOEXEC", 0))
"""Never blocks on open (a FIFO without a writer) and never takes a terminal."""


def read_text_file(path: Path, max_bytes: int, *, what: str = "the file",
                   error: Callable[[str], InputError] = InputError) -> str:
    """The text of ``path`` (UTF-8), at most ``max_bytes``; raises ``error(message)``."""
    data = read_bytes_file(path, max_bytes, what=what, error=error)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise error(f"{path}: not UTF-8 text (byte {err.start})") from err


def read_bytes_file(path: Path, max_bytes: int, *, what: str = "the file",
                    error: Callable[[str], InputError] = InputError) -> bytes:
    """The bytes of ``path``, a regular file of at most ``max_bytes``; raises
    ``error(message)``."""
    try:
        fd = os.open(path, _OPEN)
    except IsADirectoryError:
        raise error(f"{path}: is a folder; give {what}") from None
    except OSError as err:
        raise error(f"{path}: cannot read: {err.strerror or err}") from err
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise error(f"{path}: is a folder; give {what}")
        if not stat.S_ISREG(st.st_mode):
            raise error(f"{path}: not a regular file (a device, pipe or socket); give {what}")
        if st.st_size > max_bytes:
            raise error(f"{path}: {st.st_size} bytes; {what} holds at most {max_bytes} bytes")
        with os.fdopen(fd, "rb") as f:
            fd = -1
            # as much as the file holds (not a buffer of max_bytes), and what it grew by
            data = f.read(st.st_size + 1)
            if len(data) > st.st_size:
                data += f.read(max_bytes + 1 - len(data))
    except OSError as err:
        raise error(f"{path}: cannot read: {err.strerror or err}") from err
    finally:
        if fd >= 0:
            os.close(fd)
    if len(data) > max_bytes:
        raise error(f"{path}: more than {max_bytes} bytes")
    return data
