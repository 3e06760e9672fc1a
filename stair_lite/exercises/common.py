"""What every exercise checker needs: calling the learner's function and checking what it returned."""
from __future__ import annotations

import numpy as np


def call(fn, *args):
    """Call the learner's function; a stub that still raises NotImplementedError gets a clear message."""
    try:
        return fn(*args)
    except NotImplementedError:
        raise AssertionError(f"{getattr(fn, '__name__', 'the function')} raised NotImplementedError: "
                             "replace the stub's body with your code") from None


def as_array(value, shape, what: str) -> np.ndarray:
    """The learner's answer as a float array of the expected shape (a clear message if it is not)."""
    if value is None:
        raise AssertionError(f"{what} returned None: fill in the function body (it still looks like the stub)")
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != shape:
        raise AssertionError(f"{what} returned shape {arr.shape}, expected {shape}")
    return arr
