"""Checkers for the exercises of notebook 07 (when the labels lie).

``check_class_entropy`` compares the learner's entropy of class distributions with one computed here, on random
distributions and on ones with exact zeros, and names five mistakes: bits instead of nats, 0 ln 0 left as NaN,
the sum over the wrong axis, the sign, and an entropy divided by ln P. ``check_soft_exploitation`` compares the
learner's soft-mask exploitation score with one computed here, on views with one and with two target classes,
and names five mistakes: the argmax mask instead of the target probability, the largest target probability
instead of their sum, background counted as a target, the probability of any object instead of a target, and
a score that is not one number per view. On success each prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np

from .common import call as _call, compares_with, diagnose


def _entropy(p: np.ndarray, axis: int = -1) -> np.ndarray:
    safe = np.where(p > 0, p, 1.0)
    return -(p * np.log(safe)).sum(axis=axis)


def _entropy_variants(p: np.ndarray) -> dict[str, np.ndarray]:
    with np.errstate(divide="ignore", invalid="ignore"):
        nan_at_zero = -(p * np.log(p)).sum(axis=-1)
    return {"right": _entropy(p), "bits": _entropy(p) / np.log(2), "nan": nan_at_zero,
            "axis": _entropy(p, axis=0), "sign": -_entropy(p), "normalised": _entropy(p) / np.log(p.shape[-1])}


_ENTROPY_HINTS = {
    "nan": "0 ln 0 must count as 0 (the limit of p ln p), not NaN: a distribution with an exact zero is common "
           "(a ray the map is sure about); skip the zero terms, e.g. with np.where or scipy.special.xlogy",
    "bits": "the utility's entropies are in nats: use the natural log (np.log), not log2",
    "axis": "sum over the classes, the LAST axis (axis=-1), so each ray keeps its own entropy",
    "sign": "entropy is -sum_c p_c ln p_c, which is >= 0: mind the minus sign",
    "normalised": "do not divide by ln P: H_sem is the plain entropy, ln P at most (uniform over P classes)",
}


def _class_entropy_reference(sem):
    return _entropy(np.asarray(sem, dtype=np.float64))


@compares_with(_class_entropy_reference)
def check_class_entropy(fn, seed: int = 0) -> bool:
    """Check ``fn(sem)`` -> H_sem, the entropy [nats] of each class distribution along the last axis of ``sem``
    (N, P), one number per row."""
    rng = np.random.default_rng(seed)
    cases = [rng.dirichlet(np.ones(7), size=5)]
    sure = np.zeros((5, 7))
    sure[np.arange(5), [0, 2, 2, 4, 6]] = 1.0
    cases.append(sure)  # one-hot rows: entropy 0
    split = np.zeros((5, 7))
    split[:, 2], split[:, 4] = [0.5, 0.1, 0.9, 0.3, 1.0], [0.5, 0.9, 0.1, 0.7, 0.0]
    cases.append(split)  # chair against sofa, with exact zeros elsewhere
    cases.append(rng.dirichlet(np.full(7, 0.3), size=7))
    answers, variants = [], {k: [] for k in ("right", *_ENTROPY_HINTS)}
    for sem in cases:
        got = _call(fn, sem.copy())
        right = _entropy(sem)
        arr = np.asarray(got, dtype=np.float64) if got is not None else None
        for name, value in _entropy_variants(sem).items():
            variants[name].append(_key(value))
        answers.append(_key(arr))
        if arr is None or arr.shape != right.shape or not np.allclose(arr, right, atol=1e-6, equal_nan=False):
            hint = diagnose(answers, variants, _ENTROPY_HINTS, fallback="compare with the entropy of a distribution over the classes, row by row, on a uniform row and a one-hot row")
            shown = "None" if arr is None else f"shape {arr.shape}: {np.round(arr, 4)}"
            raise AssertionError(f"for sem =\n{np.round(sem, 3)}\nexpected {np.round(right, 4)}, got {shown}; {hint}")
    print(f"class_entropy: correct on {len(cases)} sets of class distributions (random, one-hot and split ones)")
    return True


def _key(value) -> tuple | None:
    """An answer as a hashable, comparable key (rounded), for ``diagnose``."""
    if value is None:
        return None
    arr = np.asarray(value, dtype=np.float64)
    return (arr.shape, tuple(np.round(np.nan_to_num(arr, nan=-999.0), 5).ravel()))


def _soft_variants(h_ray: np.ndarray, sem: np.ndarray, targets: tuple[int, ...]) -> dict[str, np.ndarray]:
    v = len(h_ray)
    p_target = sem[..., list(targets)].sum(-1)
    argmax = np.isin(sem.argmax(-1), targets)
    return {"right": (h_ray * p_target).reshape(v, -1).sum(1),
            "argmax": (h_ray * argmax).reshape(v, -1).sum(1),
            "max": (h_ray * sem[..., list(targets)].max(-1)).reshape(v, -1).sum(1),
            "background": (h_ray * sem[..., [0, *targets]].sum(-1)).reshape(v, -1).sum(1),
            "any_object": (h_ray * (1.0 - sem[..., 0])).reshape(v, -1).sum(1),
            "total": np.full(v, (h_ray * p_target).sum())}


_SOFT_HINTS = {
    "argmax": "that is the paper's hard mask (argmax S in targets); the soft mask weighs each ray by p_T(r), the "
              "rendered probability of the target classes",
    "max": "p_T(r) is the probability that the ray shows ANY target: the SUM of the target classes' probabilities, "
           "not the largest of them",
    "background": "background (class 0) is never a target: sum only the classes in targets",
    "any_object": "1 - S_background is the probability of any object; the mask wants the targets only",
    "total": "return one score per view (an array of length V): sum over each view's pixels, not over all views",
}


def _soft_reference(h_ray, sem, targets):
    h_ray, sem = np.asarray(h_ray, dtype=np.float64), np.asarray(sem, dtype=np.float64)
    return _soft_variants(h_ray, sem, tuple(targets))["right"]


@compares_with(_soft_reference)
def check_soft_exploitation(fn, seed: int = 0) -> bool:
    """Check ``fn(h_ray, sem, targets)`` -> U_et with the soft mask, sum over each view's rays of H(r) p_T(r):
    ``h_ray`` (V, H, W), ``sem`` (V, H, W, P), ``targets`` a tuple of class ids; returns (V,)."""
    rng = np.random.default_rng(seed)
    cases = []
    for targets, concentration in (((2,), 0.5), ((2, 4), 0.5), ((1, 3), 0.2), ((2,), 2.0)):
        h_ray = rng.uniform(0.0, 2.0, size=(3, 4, 5))
        sem = rng.dirichlet(np.full(7, concentration), size=(3, 4, 5))
        cases.append((h_ray, sem, targets))
    answers, variants = [], {k: [] for k in ("right", *_SOFT_HINTS)}
    for h_ray, sem, targets in cases:
        got = _call(fn, h_ray.copy(), sem.copy(), targets)
        right = _soft_variants(h_ray, sem, targets)["right"]
        for name, value in _soft_variants(h_ray, sem, targets).items():
            variants[name].append(_key(value))
        try:
            arr = np.asarray(got, dtype=np.float64)
        except (TypeError, ValueError):
            raise AssertionError(f"soft_exploitation should return an array of V = {len(h_ray)} numbers, got {got!r}") from None
        if arr.shape == ():
            arr = np.full(len(h_ray), float(arr))  # one number for all views: compared as the "total" mistake
        answers.append(_key(arr))
        if arr.shape != right.shape or not np.allclose(arr, right, rtol=1e-6, atol=1e-9):
            hint = diagnose(answers, variants, _SOFT_HINTS, fallback="compare with the section's soft mask on one view of two rays: what weighs each ray's entropy")
            raise AssertionError(f"for targets {targets}: expected {np.round(right, 4)}, got {np.round(arr, 4)}; {hint}")
    print(f"soft_exploitation: correct on {len(cases)} sets of 3 views (one and two target classes)")
    return True
