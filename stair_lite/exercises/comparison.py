"""Checkers for the exercise of notebook 06 (comparing planners over seeds).

``check_welch_p_value`` calls the learner's function on seeded random samples (plus a few built to
expose one mistake each), compares it with Welch's test computed here from its formula, and raises
``AssertionError`` with a hint when they differ: Student's pooled-variance test, the population
standard deviation (ddof=0), a one-sided p-value and normal instead of t tails each get named.
On success it prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np
from scipy.stats import norm, t

from .common import call as _call


def _welch_variants(a: np.ndarray, b: np.ndarray) -> dict[str, float]:
    """The right p-value and what a few plausible mistakes give."""
    na, nb = len(a), len(b)
    va, vb = a.var(ddof=1) / na, b.var(ddof=1) / nb
    stat = (a.mean() - b.mean()) / np.sqrt(va + vb)
    df = (va + vb) ** 2 / (va ** 2 / (na - 1) + vb ** 2 / (nb - 1))
    pooled = ((na - 1) * a.var(ddof=1) + (nb - 1) * b.var(ddof=1)) / (na + nb - 2)
    stat_pooled = (a.mean() - b.mean()) / np.sqrt(pooled * (1 / na + 1 / nb))
    va0, vb0 = a.var() / na, b.var() / nb
    stat0 = (a.mean() - b.mean()) / np.sqrt(va0 + vb0)
    df0 = (va0 + vb0) ** 2 / (va0 ** 2 / (na - 1) + vb0 ** 2 / (nb - 1))
    return {
        "right": float(2 * t.sf(abs(stat), df)),
        "student": float(2 * t.sf(abs(stat_pooled), na + nb - 2)),
        "ddof0": float(2 * t.sf(abs(stat0), df0)),
        "one_sided": float(t.sf(abs(stat), df)),
        "normal": float(2 * norm.sf(abs(stat))),
    }


_HINTS = {
    "student": "you pooled the two variances (Student's t-test); Welch's test keeps var(a)/n_a + var(b)/n_b "
               "and uses the Welch-Satterthwaite degrees of freedom",
    "ddof0": "use the sample variance with ddof=1 (numpy's var() defaults to ddof=0)",
    "one_sided": "the p-value is two-sided: 2 * P(T > |t|)",
    "normal": "with so few seeds the tails are Student t's with the Welch-Satterthwaite degrees of freedom, "
              "not the normal distribution's",
}


def check_welch_p_value(fn, n_random: int = 40, seed: int = 0) -> bool:
    """Check ``fn(a, b)`` -> the two-sided p-value of Welch's t-test between two 1-D arrays."""
    rng = np.random.default_rng(seed)
    cases = [(np.array([14.1, 13.2, 15.0]), np.array([17.6, 17.1, 18.3, 16.9, 17.4])),  # unequal sizes and spreads
             (np.array([0.31, 0.35, 0.30, 0.33, 0.36]), np.array([0.29, 0.45, 0.20, 0.41, 0.25]))]
    for _ in range(n_random):
        na, nb = rng.integers(2, 8, size=2)
        cases.append((rng.normal(rng.normal(), rng.uniform(0.2, 2), na), rng.normal(rng.normal(), rng.uniform(0.2, 2), nb)))
    for a, b in cases:
        got = _call(fn, a.copy(), b.copy())
        try:
            got = float(got)
        except (TypeError, ValueError):
            raise AssertionError(f"welch_p_value should return one number, got {got!r}") from None
        variants = _welch_variants(a, b)
        if np.isclose(got, variants["right"], rtol=1e-6, atol=1e-12):
            continue
        for name, value in variants.items():
            if name != "right" and np.isclose(got, value, rtol=1e-6, atol=1e-12):
                raise AssertionError(f"for a = {np.round(a, 3)}, b = {np.round(b, 3)}: got p = {got:.6g}; {_HINTS[name]}")
        raise AssertionError(f"for a = {np.round(a, 3)}, b = {np.round(b, 3)}: got p = {got:.6g}, expected "
                             f"{variants['right']:.6g}")
    print(f"welch_p_value: correct on {len(cases)} pairs of samples")
    return True
