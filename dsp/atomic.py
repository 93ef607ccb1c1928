"""The one atomic-output helper: an output file appears whole or not at all.

:class:`AtomicFile` for writers that live across calls (a sink commits when a replay ends);
:func:`atomic_output` for a block that writes a file in one go.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from dsp.errors import OutputExistsError

__all__ = ["AtomicFile", "atomic_output"]


class AtomicFile:
    """A new file written under a temporary name beside ``path``: :meth:`commit` renames it
    onto ``path``, :meth:`discard` removes it (a no-op after a commit).

    Raises :class:`~dsp.errors.OutputExistsError` before anything is written when ``path``
    exists and ``force`` is false. The temporary file is created empty; the caller writes it
    (by name, so writers that open the path themselves work too).
    """

    def __init__(self, path: Path | str, *, force: bool) -> None:
        self.path = Path(path)
        if self.path.exists() and not force:
            raise OutputExistsError(self.path)
        fd, tmp_name = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".tmp",
                                        dir=self.path.parent)
        os.close(fd)
        self.tmp = Path(tmp_name)

    def commit(self) -> None:
        # mkstemp makes the file private (0600); give it the mode any new file would get
        umask = os.umask(0)
        os.umask(umask)
        self.tmp.chmod(0o666 & ~umask)
        os.replace(self.tmp, self.path)

    def discard(self) -> None:
        self.tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def atomic_output(path: Path | str, *, force: bool) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` when the block
    succeeds, remove it otherwise (also on Ctrl-C). Refuses an existing ``path`` unless
    ``force`` (see :class:`AtomicFile`)."""
    out = AtomicFile(path, force=force)
    try:
        yield out.tmp
    except BaseException:
        out.discard()
        raise
    out.commit()
