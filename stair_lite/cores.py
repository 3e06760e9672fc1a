"""Who runs on the CPU's cores: torch's threads, not numpy's BLAS.

numpy hands a large matrix product to its BLAS (OpenBLAS), which starts threads of its own. Beside torch's threads,
which keep spinning for a while after each parallel operation, the two pools take turns on the same cores: the
160000 x 3 @ 3 x 3 product of ``geometry.pixel_rays`` for one 400 x 400 view took 50-65 ms on two BLAS threads against
0.6 ms on one (a 2-core machine, torch on two threads): a paper evaluation (100 such views) took 25.2 s against 21.8 s
with one BLAS thread (README, "Measured figures"). The products
numpy computes here are all small, so its BLAS runs on one thread: the same numbers (a product's rows do not depend on
how they are split among threads), without the contention. Only the BLAS libraries loaded when this runs are limited
(numpy's: importing the package loads it).
"""
from threadpoolctl import threadpool_limits


def numpy_blas_on_one_thread() -> None:
    """Limit the loaded BLAS libraries (numpy's OpenBLAS) to one thread; torch's own thread count is left alone."""
    threadpool_limits(1, user_api="blas")
