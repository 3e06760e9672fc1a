"""Checkers for the exercise of notebook 06 (comparing planners over seeds).

``check_paired_p_value`` calls the learner's function on seeded random pairs of samples (plus a few built to
expose one mistake each), compares it with the paired t-test computed here from its formula, and raises
``AssertionError`` with a hint when they differ: an unpaired test (Welch's or Student's), the population
standard deviation (ddof=0), a one-sided p-value and normal instead of t tails each get named.
On success it prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np
from scipy.stats import norm, t

from .common import call as _call, compares_with


def _paired_variants(a: np.ndarray, b: np.ndarray) -> dict[str, float]:
    """The right p-value and what a few plausible mistakes give."""
    d, n = a - b, len(a)
    stat = d.mean() / (d.std(ddof=1) / np.sqrt(n))
    stat0 = d.mean() / (d.std() / np.sqrt(n))
    va, vb = a.var(ddof=1) / n, b.var(ddof=1) / n
    stat_welch = (a.mean() - b.mean()) / np.sqrt(va + vb)
    df_welch = (va + vb) ** 2 / (va ** 2 / (n - 1) + vb ** 2 / (n - 1))
    pooled = (a.var(ddof=1) + b.var(ddof=1)) / 2
    stat_student = (a.mean() - b.mean()) / np.sqrt(pooled * 2 / n)
    return {
        "right": float(2 * t.sf(abs(stat), n - 1)),
        "welch": float(2 * t.sf(abs(stat_welch), df_welch)),
        "student": float(2 * t.sf(abs(stat_student), 2 * n - 2)),
        "ddof0": float(2 * t.sf(abs(stat0), n - 1)),
        "one_sided": float(t.sf(abs(stat), n - 1)),
        "normal": float(2 * norm.sf(abs(stat))),
    }


_HINTS = {
    "welch": "that is an unpaired test (Welch's or Student's): pair the scores by seed and test the per-seed differences a - b",
    "student": "that is an unpaired test (Welch's or Student's): pair the scores by seed and test the per-seed differences a - b",
    "ddof0": "use the sample standard deviation of the differences, ddof=1 (numpy's std() defaults to ddof=0)",
    "one_sided": "the p-value is two-sided: 2 * P(T > |t|)",
    "normal": "with so few seeds the tails are Student t's with n - 1 degrees of freedom, not the normal distribution's",
}


def _p_value_reference(a, b):
    return _paired_variants(np.asarray(a, dtype=float), np.asarray(b, dtype=float))["right"]


@compares_with(_p_value_reference)
def check_paired_p_value(fn, n_random: int = 40, seed: int = 0) -> bool:
    """Check ``fn(a, b)`` -> the two-sided p-value of the paired t-test between two 1-D arrays of per-seed scores
    (entry k of both from seed k)."""
    rng = np.random.default_rng(seed)
    seed_effect = np.array([18.0, 22.0, 20.0, 25.0, 16.0])
    cases = [(seed_effect + np.array([0.3, 0.1, 0.2, 0.4, 0.2]), seed_effect),  # large seed-to-seed spread
             (np.array([0.31, 0.35, 0.30, 0.33, 0.36]), np.array([0.29, 0.45, 0.20, 0.41, 0.25]))]
    for _ in range(n_random):
        n = int(rng.integers(3, 9))
        shared = rng.normal(0, rng.uniform(0.2, 2), n)
        cases.append((shared + rng.normal(rng.normal(), 0.3, n), shared + rng.normal(rng.normal(), 0.3, n)))
    for a, b in cases:
        got = _call(fn, a.copy(), b.copy())
        try:
            got = float(got)
        except (TypeError, ValueError):
            raise AssertionError(f"paired_p_value should return one number, got {got!r}") from None
        if not 0.0 <= got <= 1.0:
            raise AssertionError(f"for a = {np.round(a, 3)}, b = {np.round(b, 3)}: got p = {got:.6g}, which is no "
                                 "probability (a p-value lies in [0, 1]): return 2 * P(T > |t|), the tail beyond |t|, "
                                 "not the statistic t or the cdf of a negative t doubled")
        variants = _paired_variants(a, b)
        if np.isclose(got, variants["right"], rtol=1e-6, atol=1e-12):
            continue
        for name, value in variants.items():
            if name != "right" and np.isclose(got, value, rtol=1e-6, atol=1e-12):
                raise AssertionError(f"for a = {np.round(a, 3)}, b = {np.round(b, 3)}: got p = {got:.6g}; {_HINTS[name]}")
        raise AssertionError(f"for a = {np.round(a, 3)}, b = {np.round(b, 3)}: got p = {got:.6g}, expected "
                             f"{variants['right']:.6g}")
    print(f"paired_p_value: correct on {len(cases)} pairs of per-seed scores")
    return True
