"""allocator.py: freed blocks stay in the heap for reuse until a mission hands them back between its phases."""
import sys

import pytest
import torch

from stair_lite.allocator import _glibc, keep_freed_memory, release_freed_memory

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux") or _glibc() is None, reason="glibc only")

BLOCK = 256 * 2**20  # bytes: below the mmap threshold, far above glibc's default trim threshold (128 kB)


def resident_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096


def test_a_freed_block_stays_resident_until_released():
    assert keep_freed_memory()
    release_freed_memory()
    before = resident_bytes()
    block = torch.ones(BLOCK // 4)  # touched: every page resident
    with_block = resident_bytes()
    assert with_block - before > 0.9 * BLOCK
    del block
    assert resident_bytes() > with_block - 0.1 * BLOCK  # kept for the next allocation (no page faults then)
    assert release_freed_memory()
    assert resident_bytes() < with_block - 0.9 * BLOCK  # handed back to the system
