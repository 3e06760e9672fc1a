"""Checkers for the notebooks' exercises: each takes the learner's function and raises AssertionError
with a hint when it is wrong (one module per notebook topic)."""

from .common import mine_or_reference  # noqa: E402,F401  (the cells after an exercise)
