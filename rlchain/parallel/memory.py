"""glibc's malloc for a training process (``params.malloc``): keep freed memory for the next allocation.

A PPO epoch allocates and frees the same few-MB tensors over and over (a (16,384 x 64) activation is 4 MB).
With glibc's defaults each one above its adaptive mmap threshold, or on top of a heap it trims after every
free, comes back as fresh pages from the kernel: a page fault and a zeroing per 4 KB, then cold caches for
the kernel that reads them, which makes the update's matmuls and activations slower than the same ops on
warm memory (the tensor-env update most of all; envpool runs are bound by the env). ``keep`` raises the mmap
threshold to glibc's maximum (32 MiB) and stops trimming, so freed blocks are reused; memory is not returned to
the OS until the process ends.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import platform

from rlchain.log import get_logger

_log = get_logger(__name__)

M_TRIM_THRESHOLD = -1  # glibc's mallopt parameter numbers (malloc.h)
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 32 * 1024 * 1024  # glibc's largest accepted value on 64-bit
TRIM_THRESHOLD = 2**31 - 1  # mallopt takes a C int: keep up to 2 GB of free memory at the heap's top
_applied: set[str] = set()


def _glibc() -> ctypes.CDLL | None:
    """The C library when it is glibc (Linux), else None: musl, macOS and Windows have no mallopt to tune."""
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    except OSError:
        return None


def tune_malloc(mode: str = "keep") -> bool:
    """Apply ``params.malloc`` to this process (once; later calls are no-ops). True when glibc took the
    settings; False for ``default``, on a C library other than glibc, or when mallopt refused them."""
    if mode != "keep":
        return False
    if _applied:
        return True
    libc = _glibc()
    if libc is None:
        return False
    ok = bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
    if ok:
        _applied.add("keep")
    else:
        _log.warning("params.malloc: keep: glibc's mallopt refused the settings; malloc stays as it was")
    return ok
