"""Keep freed image buffers mapped: glibc malloc tuning for a replaying process.

A decoded 1080 x 1080 BGR image is 3.5 MB, and every frame allocates one and frees it again
a few frames later. glibc serves an allocation that large with ``mmap`` and gives it back with
``munmap``, or (once its adaptive threshold has risen) from the heap, whose free top it
returns to the kernel when it passes a trim threshold (adaptive too: twice the largest buffer
seen). With images, the decoder's working memory and the log's chunks coming and going, the
heap's top often passes it, so the next image's memory is fresh and each of its 4 kB pages
faults on first touch: in a 180-frame recorded JPEG log ~1700 minor page faults a frame with
``--threads 1``, more CPU than the decoding itself
(``python benchmarks/bench_replay.py --recorded --malloc`` prints both).

:func:`keep_image_buffers` fixes both thresholds (``mallopt``): buffers up to 32 MiB come from
the heap, and up to 16 MiB of free heap stays mapped for the next images, which then reuse
pages already faulted in. It changes only when memory goes back to the kernel, never what is
computed, so outputs are the same bytes. It acts on the whole process, so ``dsp-replay`` (and
each batch worker) calls it, not :func:`replay.replay`; a program embedding the replay may
call it too. On a C library other than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import platform

__all__ = ["MMAP_THRESHOLD", "TRIM_THRESHOLD", "keep_image_buffers"]

MMAP_THRESHOLD = 32 << 20
"""Allocations under this many bytes come from the heap (glibc's largest adaptive value)."""
TRIM_THRESHOLD = 16 << 20
"""Free heap kept mapped before glibc gives it back to the kernel (bytes)."""

_M_TRIM_THRESHOLD = -1  # <malloc.h>
_M_MMAP_THRESHOLD = -3


def keep_image_buffers() -> bool:
    """Set glibc's mmap and trim thresholds (:data:`MMAP_THRESHOLD`, :data:`TRIM_THRESHOLD`)
    for this process; True when they were set, False when the C library is not glibc."""
    if platform.libc_ver()[0] != "glibc":
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # pragma: no cover - glibc always has mallopt
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
                and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))
