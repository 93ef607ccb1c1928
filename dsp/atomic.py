"""The one atomic-output helper: an output file appears whole or not at all."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from dsp.errors import OutputExistsError

__all__ = ["atomic_output"]


@contextlib.contextmanager
def atomic_output(path: Path | str, *, force: bool) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` when the block
    succeeds, remove it otherwise (also on Ctrl-C).

    Raises :class:`~dsp.errors.OutputExistsError` before anything is written when ``path``
    exists and ``force`` is false. The temporary file is created empty; the block writes it
    (by name, so writers that open the path themselves work too).
    """
    path = Path(path)
    if path.exists() and not force:
        raise OutputExistsError(path)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    # mkstemp makes the file private (0600); give it the mode any new file would get
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o666 & ~umask)
    os.replace(tmp, path)
