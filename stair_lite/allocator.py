"""Keep freed tensor memory for reuse (glibc only).

A training iteration allocates and frees tensors of tens to hundreds of MB (samples x MLP widths). glibc
serves blocks above its mmap threshold (at most 32 MB, adjusted at run time) straight from the kernel and
returns them on free, so every iteration page-faults the same memory in again: at the paper preset half
of an iteration's time was the kernel zeroing pages (``benchmarks/bench_paper_cpu.py``, README). Raising
the threshold keeps such blocks in the heap, where the next iteration reuses them; raising the trim threshold
with it keeps glibc from handing a freed block at the heap's top straight back (its default, 128 kB, did so
for every large block freed last: a planning step's 46 MB sample table was faulted in again per candidate). The heap then holds
the largest working set of any phase (training, evaluation, planning) and fragments across them, so a
mission hands the freed blocks back between its phases (``release_freed_memory``): a phase's first
allocations fault their pages in once, and the mission's peak is that of its largest phase, not their sum.
Elsewhere (macOS, Windows, musl) both do nothing.
"""
import ctypes
import ctypes.util
import sys

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # mallopt's parameter numbers (malloc.h)
MMAP_THRESHOLD = 1 << 30  # bytes: blocks below 1 GiB come from the reusable heap
TRIM_THRESHOLD = 1 << 30  # bytes: free memory at the heap's top is kept up to 1 GiB (until release_freed_memory)


def _glibc():
    """The C library when it is glibc on Linux, else None."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        return libc if hasattr(libc, "mallopt") and hasattr(libc, "malloc_trim") else None
    except OSError:
        return None


def keep_freed_memory() -> bool:
    """Raise glibc's mmap and trim thresholds; True when the C library took both settings."""
    libc = _glibc()
    return libc is not None and bool(libc.mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
        libc.mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))


def release_freed_memory() -> bool:
    """Return the heap's free pages to the system (glibc's malloc_trim); True when some were returned."""
    libc = _glibc()
    return libc is not None and bool(libc.malloc_trim(0))
