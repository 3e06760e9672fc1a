"""What every exercise checker needs: calling the learner's function and checking what it returned; and
what the cells after an exercise need: the learner's function once it passes, the checker's reference before."""
from __future__ import annotations

import contextlib
import io
import warnings

import numpy as np


def diagnose(answers: list, variants: dict[str, list], hints: dict[str, str], fallback: str) -> str:
    """The hint of the first plausible mistake that gives the learner's answer in EVERY case where that answer is
    wrong (``variants[name][i]``: what mistake ``name`` answers in case i; ``variants["right"]`` the right ones), so
    that one coincidence in one case cannot pick the hint; ``fallback`` when no single mistake explains them all."""
    wrong = [i for i, (got, right) in enumerate(zip(answers, variants["right"])) if got != right]
    for name, hint in hints.items():
        if all(variants[name][i] == answers[i] for i in wrong):
            return hint
    return fallback


def compares_with(reference):
    """Decorator for a checker: remember the independent computation it compares against (in the exercise's
    signature), so that ``mine_or_reference`` can stand it in for an answer that does not pass yet."""
    def attach(check):
        check.reference = reference
        return check
    return attach


def mine_or_reference(mine, check):
    """The learner's function when ``check`` accepts it; otherwise the checker's reference, with a printed note.
    The cells after an exercise run either way, so Run All of a student notebook goes to the end."""
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            check(mine)
        return mine
    except Exception as err:  # the checker's hint, or whatever the learner's code raised
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        print(f"note: {getattr(mine, '__name__', 'your function')} does not pass its check yet ({reason}); "
              "the cells below use the reference instead")
        return check.reference


def describe(value) -> str:
    """A short description of an argument for an error message: its type and, for arrays, tensors and dicts, its shape."""
    if hasattr(value, "shape") and hasattr(value, "dtype"):
        return f"{type(value).__name__} of shape {tuple(value.shape)} ({value.dtype})"
    if isinstance(value, dict):
        return "dict {" + ", ".join(f"{k!r}: {describe(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (int, float, str, bool)) or value is None:
        return repr(value)
    return type(value).__name__


_WARNED: set = set()  # (function, warning) pairs already shown in this session


def call(fn, *args):
    """Call the learner's function. A stub that still raises NotImplementedError, or code that raises anything else,
    gets a message that names the function, the error and the arguments it was called with (the traceback above it
    still shows the line). A warning the function gives is shown once as a printed note instead of on stderr, where
    nbgrader would take it for a failure."""
    name = getattr(fn, "__name__", "the function")
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = fn(*args)
        for message in dict.fromkeys(str(w.message).splitlines()[0] for w in caught):
            if (name, message) not in _WARNED:
                _WARNED.add((name, message))
                print(f"note: {name} warned: {message}")
        return result
    except NotImplementedError:
        raise AssertionError(f"{name} raised NotImplementedError: replace the stub's body with your code") from None
    except Exception as err:
        arguments = "\n".join(f"  argument {i + 1}: {describe(a)}" for i, a in enumerate(args))
        raise AssertionError(f"{name} raised {type(err).__name__}: {err}\nwhen the checker called it with\n{arguments}\n"
                             "(the traceback above points to the line in your code)") from err


def as_array(value, shape, what: str) -> np.ndarray:
    """The learner's answer as a float array of the expected shape (a clear message if it is not)."""
    if value is None:
        raise AssertionError(f"{what} returned None: fill in the function body (it still looks like the stub)")
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != shape:
        raise AssertionError(f"{what} returned shape {arr.shape}, expected {shape}")
    return arr
