"""Small input files (camera files, measurements) read whole, but bounded and checked first.

:func:`read_text_file` refuses, each in one line naming the file: a path that is not a
regular file (checked before opening, so a FIFO never blocks), a file over ``max_bytes``
(by its size and by what is read, should it grow meanwhile), and bytes that are not UTF-8
(a leading byte-order mark is dropped). The error is the caller's class, so each input
keeps its own name in the error tree.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path

from dsp.errors import InputError

__all__ = ["read_text_file"]


def read_text_file(path: Path, max_bytes: int, *, what: str = "the file",
                   error: Callable[[str], InputError] = InputError) -> str:
    """The text of ``path`` (UTF-8), at most ``max_bytes``; raises ``error(message)``."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise error(f"{path}: not a regular file")
        with path.open("rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size > max_bytes:
                raise error(f"{path}: {size} bytes; {what} holds at most {max_bytes} bytes")
            data = f.read(max_bytes + 1)
    except OSError as err:
        raise error(f"{path}: cannot read: {err.strerror or err}") from err
    if len(data) > max_bytes:
        raise error(f"{path}: more than {max_bytes} bytes")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise error(f"{path}: not UTF-8 text (byte {err.start})") from err
