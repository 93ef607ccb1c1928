"""The Rerun recording streams a replay opens, released when it ends (rerun-sdk 0.41).

rerun-sdk turns a ``default_blueprint`` into a stream of its own (two native threads) whose
memory sink refers back to it, so it is never freed; neither is a closed recording until
orphaned recordings are swept. A program that replays logs in a loop would gain four
threads and gigabytes of reserved address space per replay. :func:`blueprint_storage`
makes that stream itself and disconnects it once the blueprint is handed over, and
:func:`release` disconnects a recording and sweeps, so a replay leaves no thread behind
(``tests/replay/sinks/test_rerun_release.py`` replays 100 times and counts).

:func:`check_room` refuses an .rrd on a disk with almost no room before Rerun's file writer
starts: on such a disk it can block for minutes instead of failing. With more room, a writer
that a file-size limit or a full disk stops mid-way may say nothing at all: its flush and
disconnect return and the file lacks its footer, which :func:`check_complete` looks for
before the file is committed.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import uuid
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import rerun as rr
import rerun.blueprint as rrb
import rerun_bindings as bindings

from dsp.atomic import AtomicFile
from dsp.errors import OutputError
from dsp.launch import end_without_finalising

__all__ = ["MIN_FREE_BYTES", "abandon", "blueprint_storage", "check_complete", "check_room",
           "commit", "flush", "recording_id", "release"]

MIN_FREE_BYTES = 1 << 20
"""1 MiB: less room than this for an .rrd is a full disk."""
FLUSH_TIMEOUT_S = 10.0
"""How long a flush to a viewer is waited for."""
RRD_FOOTER = b"RRF2FOOT"
"""What a complete .rrd ends with (before its 4-byte version): Rerun writes it on closing."""
FLUSH_STEP_S = 0.5
FLUSH_STALLS = 3
"""A flush to an .rrd is waited for in steps of FLUSH_STEP_S for as long as the file grows;
FLUSH_STALLS steps in a row without a byte written mean its writer has stopped."""


def recording_id(digest: str, options: Mapping[str, object]) -> str:
    """A UUID derived from the log's hash and the options (same input -> same recording)."""
    text = json.dumps({"sha256": digest, "options": options}, sort_keys=True, default=str)
    return str(uuid.UUID(bytes=hashlib.sha256(text.encode()).digest()[:16], version=4))


@contextlib.contextmanager
def blueprint_storage(application_id: str, blueprint: rrb.Blueprint) -> Iterator[Any]:
    """The blueprint encoded in memory, for ``bindings.save`` / ``send_blueprint``; its
    stream is disconnected after the block (which is what frees it)."""
    stream = rr.RecordingStream._from_native(bindings.new_blueprint(
        application_id=application_id, make_default=False, make_thread_default=False,
        default_enabled=True))
    try:
        stream.set_time("blueprint", sequence=0)
        blueprint._log_to_stream(stream)
        yield stream.memory_recording().storage
    finally:
        stream.disconnect()
        del stream
        bindings.flush_and_cleanup_orphaned_recordings()


def release(rec: rr.RecordingStream) -> None:
    """Disconnect ``rec`` (closing its file or connection) and free closed recordings."""
    rec.disconnect()
    bindings.flush_and_cleanup_orphaned_recordings()


def flush(rec: rr.RecordingStream, saving: Path | None) -> None:
    """Flush ``rec``; RuntimeError when it does not finish. A recording written to the file
    ``saving`` is waited for while that file grows, so a writer stopped by a full disk or a
    file-size limit is given up in about FLUSH_STEP_S * FLUSH_STALLS seconds, while a long
    save on a slow disk still completes."""
    if saving is None:
        rec.flush(timeout_sec=FLUSH_TIMEOUT_S)
        return
    size, still = -1, 0
    while True:
        try:
            rec.flush(timeout_sec=FLUSH_STEP_S)
            return
        except RuntimeError as err:
            if "timed out" not in str(err):
                raise
            try:
                now = saving.stat().st_size
            except OSError:
                raise err from None
            still = still + 1 if now == size else 0
            size = now
            if still >= FLUSH_STALLS:
                raise


def free_bytes(folder: Path) -> int | None:
    """The bytes an unprivileged writer may still use in ``folder`` (None: unknown)."""
    try:
        st = os.statvfs(folder)
    except (OSError, AttributeError):
        return None
    return st.f_bavail * st.f_frsize


def check_room(path: Path) -> None:
    """Raise :class:`~dsp.errors.OutputError` when ``path``'s disk has less than
    :data:`MIN_FREE_BYTES` left, or the process may write no file that large."""
    free = free_bytes(path.parent)
    if free is not None and free < MIN_FREE_BYTES:
        raise OutputError(path, f"No space left on device ({free // 1024} KiB free)")
    limit = file_size_limit()
    if limit is not None and limit < MIN_FREE_BYTES:  # Rerun's writer can block as well
        raise OutputError(path, f"File too large (a file-size limit of {limit // 1024} KiB)")


def file_size_limit() -> int | None:
    """The bytes a file this process writes may hold (RLIMIT_FSIZE; None: no limit)."""
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    except (ImportError, OSError, ValueError):
        return None
    return None if soft == resource.RLIM_INFINITY else int(soft)


def abandon(rec: rr.RecordingStream) -> None:
    """Give up on ``rec`` after its file writer failed: it is never flushed again, at exit
    neither. Rerun's exit handler flushes every recording and waits without a limit for a
    writer that stopped (a file-size limit: the command printed its error and never
    ended), and so does collecting the recording: it is kept until the command ends at once
(:func:`dsp.launch.end_without_finalising`)."""
    with contextlib.suppress(Exception):
        rr.unregister_shutdown()
    end_without_finalising(rec)  # collecting it would flush it, and wait for ever


def commit(rec: rr.RecordingStream, save: AtomicFile) -> None:
    """Close ``rec``, saved to ``save``'s temporary, and rename the .rrd into place once
    :func:`check_complete` finds it whole (its footer is written on closing)."""
    release(rec)
    check_complete(save.tmp, save.path)
    save.commit()


def check_complete(tmp: Path, path: Path) -> None:
    """Raise :class:`~dsp.errors.OutputError` naming ``path`` when the closed .rrd ``tmp``
    (its temporary) does not end with Rerun's footer: its writer stopped before the end."""
    try:
        with tmp.open("rb") as f:
            size = f.seek(0, os.SEEK_END)
            f.seek(max(0, size - len(RRD_FOOTER) - 4))
            tail = f.read()
    except OSError as err:
        raise OutputError(path, err) from err
    if tail[:len(RRD_FOOTER)] == RRD_FOOTER:
        return
    stopped = f"the Rerun file writer stopped after {size} bytes, before the recording's end"
    limit, free = file_size_limit(), free_bytes(path.parent)
    if limit is not None and size >= limit - (1 << 16):
        raise OutputError(path, f"File too large (a file-size limit of {limit // 1024} KiB): "
                          + stopped)
    if free is not None and free < MIN_FREE_BYTES:
        raise OutputError(path, f"No space left on device: {stopped}")
    raise OutputError(path, f"{stopped}; is the disk full, or a file-size limit reached?")


def write_failure(path: Path, err: RuntimeError, rec: rr.RecordingStream) -> OutputError:
    """What a failing Rerun file writer means, naming the output; ``rec``, the recording
    it wrote, is given up (:func:`abandon`)."""
    abandon(rec)
    free = free_bytes(path.parent)
    if free is not None and free < MIN_FREE_BYTES:
        return OutputError(path, "No space left on device")
    text = str(err)
    if "Flush timed out" in text:
        return OutputError(path, "the Rerun file writer did not finish in time; is the disk "
                           "full, or a file-size limit reached?")
    if "os error" in text or "File too large" in text or "shut down prematurely" in text:
        return OutputError(path, f"the Rerun file writer stopped ({text}); is the disk full?")
    return OutputError(path, text)
