"""Who runs on the CPU's cores: torch's threads, not the BLAS of numpy and scipy.

numpy hands a large matrix product to its BLAS (OpenBLAS), which starts threads of its own. Beside torch's threads,
which keep spinning for a while after each parallel operation, the two pools take turns on the same cores: the
160000 x 3 @ 3 x 3 product of ``geometry.pixel_rays`` for one 400 x 400 view took 50-65 ms on two BLAS threads against
0.6 ms on one (a 2-core machine, torch on two threads): a paper evaluation (100 such views) took 25.2 s against 21.8 s
with one BLAS thread (README, "Measured figures"). The products numpy and scipy compute here are all small, so their
OpenBLAS runs on one thread: the same numbers (a product's rows do not depend on how they are split among threads),
without the contention. torch's own threads and BLAS are left alone.
"""
import os

from threadpoolctl import ThreadpoolController


def blas_on_one_thread() -> None:
    """OpenBLAS on one thread: the copies already loaded now, and those loaded later (numpy's and scipy's each bring
    one) through ``OPENBLAS_NUM_THREADS``, which OpenBLAS reads when it loads. A user's own ``OPENBLAS_NUM_THREADS``
    is kept."""
    if "OPENBLAS_NUM_THREADS" in os.environ:
        return
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    ThreadpoolController().select(internal_api="openblas").limit(limits=1)
