"""Keep freed tensor memory for reuse (glibc only).

A training iteration allocates and frees tensors of tens to hundreds of MB (samples x MLP widths). glibc
serves blocks above its mmap threshold (at most 32 MB, adjusted at run time) straight from the kernel and
returns them on free, so every iteration page-faults the same memory in again: at the paper preset half
of an iteration's time was the kernel zeroing pages (``benchmarks/bench_paper_cpu.py``, README). Raising
the threshold keeps such blocks in the heap, where the next iteration reuses them. Elsewhere (macOS,
Windows, musl) this does nothing.
"""
import ctypes
import ctypes.util
import sys

M_MMAP_THRESHOLD = -3  # mallopt's parameter number (malloc.h)
MMAP_THRESHOLD = 1 << 30  # bytes: blocks below 1 GiB come from the reusable heap


def keep_freed_memory() -> bool:
    """Raise glibc's mmap threshold; True when the C library took the setting."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD))
    except (OSError, AttributeError):  # not glibc
        return False
