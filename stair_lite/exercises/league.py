"""Checkers for the exercise of notebook 08 (the headroom instrument's noise ceiling).

``check_noise_ceiling`` calls the learner's ``noise_ceiling(gains)`` on seeded random tables of realised gains (streams
x views, a view's gains related across streams as in the stored tables) and a few tables built to expose one mistake
each, compares it with the oracle computed here from its definition, and raises ``AssertionError`` with a hint when
they differ: the oracle that sees its own stream, Pearson's correlation instead of Spearman's, ties counted as beaten,
the median over the other streams instead of their mean and a share over the other views only each get named. On success it prints one line and returns
``True``.
"""
from __future__ import annotations

import numpy as np
from scipy import stats

from .common import call as _call, compares_with


def _oracle(gains: np.ndarray, leave_out: bool = True, average=np.mean, correlation: str = "spearman",
            beaten=np.less) -> tuple[float, float]:
    """(mean Spearman, mean share of views beaten) of the oracle that ranks stream s by the other streams' gains."""
    rhos, picks = [], []
    for s in range(len(gains)):
        others = np.delete(gains, s, axis=0) if leave_out else gains
        oracle = average(others, axis=0)
        rho = stats.spearmanr(oracle, gains[s]).statistic if correlation == "spearman" else np.corrcoef(oracle, gains[s])[0, 1]
        rhos.append(float(rho))
        picks.append(float(beaten(gains[s], gains[s][np.argmax(oracle)]).mean()))
    return float(np.mean(rhos)), float(np.mean(picks))


def _variants(gains: np.ndarray) -> dict[str, tuple[float, float]]:
    rho, pick = _oracle(gains)
    views = gains.shape[1]
    return {"right": (rho, pick), "own_stream": _oracle(gains, leave_out=False),
            "pearson": _oracle(gains, correlation="pearson"), "ties": _oracle(gains, beaten=np.less_equal),
            "median": _oracle(gains, average=np.median), "others_only": (rho, pick * views / (views - 1))}


_HINTS = {
    "own_stream": "the oracle of stream s must not see stream s itself: average the OTHER streams' gains "
                  "(np.delete(gains, s, axis=0)), or it ranks the very gains it is judged on",
    "pearson": "the ceiling is a rank correlation (Spearman's: the Pearson correlation of the ranks, "
               "scipy.stats.spearmanr), as the league's rho is",
    "ties": "a view the oracle's pick beats has a gain strictly below the pick's (<): the pick does not beat itself",
    "median": "the oracle knows each view's MEAN gain over the other streams (with more than two other streams the "
              "median differs)",
    "others_only": "the share is over ALL the stream's views (the pick included, which does not beat itself): divide "
                   "by the number of views, not by the number of the others",
}


def _reference(gains):
    return _oracle(np.asarray(gains, dtype=float))


def _table(rng: np.random.Generator, streams: int, views: int, noise: float) -> np.ndarray:
    """Gains of ``views`` views in ``streams`` training streams: a view's own worth plus the stream's noise."""
    return rng.normal(0.1, 0.03, views)[None, :] + rng.normal(0.0, noise, (streams, views))


@compares_with(_reference)
def check_noise_ceiling(fn, n_random: int = 30, seed: int = 0) -> bool:
    """Check ``fn(gains)`` -> (spearman, pick_percentile): for a (streams, views) array of realised gains, the mean over
    the streams s of Spearman's correlation between the other streams' mean gain per view and stream s's gains, and of
    the share of stream s's views whose gain lies below that of the view the other streams' mean ranks first."""
    rng = np.random.default_rng(seed)
    # multiples of 1/8 (exact in binary): a mean computed in another order gives the same ranks, no near-ties
    cases = [np.array([[1, 3, 2, 5], [2, 1, 6, 3], [5, 3, 1, 2]]) / 8,                       # noise only
             np.array([[1, 2, 9, 4, 5], [2, 1, 3, 8, 6], [1, 3, 2, 4, 5], [2, 2, 1, 9, 3]]) / 8]  # mean and median differ
    cases += [_table(rng, int(rng.integers(2, 6)), int(rng.integers(5, 17)), rng.uniform(0.005, 0.05))
              for _ in range(n_random)]
    for gains in cases:
        got = _call(fn, gains.copy())
        try:
            rho, pick = (float(x) for x in got)
        except (TypeError, ValueError):
            raise AssertionError(f"noise_ceiling should return two numbers (spearman, pick_percentile), got {got!r}") from None
        variants = _variants(gains)
        if np.allclose((rho, pick), variants["right"], rtol=1e-6, atol=1e-9):
            continue
        for name, value in variants.items():
            if name != "right" and np.allclose((rho, pick), value, rtol=1e-6, atol=1e-9):
                raise AssertionError(f"for gains\n{np.round(gains, 3)}\ngot ({rho:.4f}, {pick:.4f}); {_HINTS[name]}")
        raise AssertionError(f"for gains\n{np.round(gains, 3)}\ngot ({rho:.4f}, {pick:.4f}), expected "
                             f"({variants['right'][0]:.4f}, {variants['right'][1]:.4f})")
    print(f"noise_ceiling: correct on {len(cases)} tables of realised gains")
    return True
