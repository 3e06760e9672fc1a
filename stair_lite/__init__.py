"""stair_lite: a teaching implementation of STAIR, semantic-targeted active implicit reconstruction.

Import this package before pyrender: offscreen rendering needs ``PYOPENGL_PLATFORM`` set before
PyOpenGL is first imported (EGL by default; export ``PYOPENGL_PLATFORM=osmesa`` to choose OSMesa).
Importing it also keeps freed tensor memory for reuse (``allocator.py``) and runs the OpenBLAS of numpy and
scipy on one thread (``cores.py``: torch owns the cores).
"""
import os

from .allocator import keep_freed_memory
from .cores import blas_on_one_thread

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
keep_freed_memory()
blas_on_one_thread()

__version__ = "0.1.0"
