"""Checkers for the exercises of notebook 06 (comparing planners over seeds; STE's voxel map).

``check_paired_p_value`` calls the learner's function on seeded random pairs of samples (plus a few built to
expose one mistake each), compares it with the paired t-test computed here from its formula, and raises
``AssertionError`` with a hint when they differ: an unpaired test (Welch's or Student's), the population
standard deviation (ddof=0), a one-sided p-value and normal instead of t tails each get named.
``check_octomap_update`` compares the learner's log-odds update of one scan with one computed voxel by voxel
here, naming five mistakes: repeated indices counted more than once, a voxel both crossed and hit updated as
free too, no clamping, the miss's sign, and overwriting instead of adding. On success each prints one line and
returns ``True``.
"""
from __future__ import annotations

import numpy as np
from scipy.stats import norm, t

from .common import as_array as _as_array, call as _call, compares_with


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


# ---------------------------------------------------------------------------------------- the OctoMap update
def _octomap_variants(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max) -> dict[str, np.ndarray]:
    """The right update of one scan, computed voxel by voxel, and what a few plausible mistakes give."""
    clamp = lambda x: min(max(x, l_min), l_max)  # noqa: E731
    hits, crossings = set(hit.tolist()), set(crossed.tolist())

    def update(free_voxels, hit_voxels, do_clamp=True, miss=l_miss, overwrite=False):
        out = np.array(log_odds, dtype=float)
        for voxels, step in ((free_voxels, miss), (hit_voxels, l_hit)):
            for v in voxels:
                value = step if overwrite else out[v] + step
                out[v] = clamp(value) if do_clamp else value
        return out

    return {
        "right": update(sorted(crossings - hits), sorted(hits)),
        "repeats": update([v for v in crossed.tolist() if v not in hits], hit.tolist()),  # each index as often as given
        "crossed_and_hit": update(sorted(crossings), sorted(hits)),
        "no_clamp": update(sorted(crossings - hits), sorted(hits), do_clamp=False),
        "miss_sign": update(sorted(crossings - hits), sorted(hits), miss=-l_miss),
        "overwrite": update(sorted(crossings - hits), sorted(hits), overwrite=True),
    }


_OCTOMAP_HINTS = {
    "repeats": "a voxel changes at most once per scan, however many of its rays cross or end in it: take the "
               "unique voxel indices (np.unique) before adding",
    "crossed_and_hit": "a voxel that one ray crosses and another ray ends in, in the same scan, counts as hit only: "
                       "leave the hit voxels out of the free update",
    "no_clamp": "clamp the log-odds to [l_min, l_max] after adding (np.clip), so that a voxel can still change its mind",
    "miss_sign": "l_miss = logit(0.4) is already negative: add it, as l_hit, do not subtract it",
    "overwrite": "add the evidence to the stored log-odds (+=): independent measurements add up in log-odds",
}
_OCTOMAP_MODEL = dict(l_hit=float(np.log(0.7 / 0.3)), l_miss=float(np.log(0.4 / 0.6)),
                      l_min=float(np.log(0.12 / 0.88)), l_max=float(np.log(0.97 / 0.03)))


def _octomap_reference(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max):
    return _octomap_variants(np.asarray(log_odds, dtype=float), np.asarray(crossed), np.asarray(hit),
                             l_hit, l_miss, l_min, l_max)["right"]


@compares_with(_octomap_reference)
def check_octomap_update(fn, n_random: int = 30, seed: int = 0) -> bool:
    """Check ``fn(log_odds, crossed, hit, l_hit, l_miss, l_min, l_max)`` -> the voxel map's log-odds after one scan:
    ``crossed`` and ``hit`` are integer voxel indices (repeats allowed: many rays per voxel), with STE's sensor
    model (hit 0.7, miss 0.4, clamps 0.12 and 0.97)."""
    rng = np.random.default_rng(seed)
    m = _OCTOMAP_MODEL
    n = 12
    cases = [(np.zeros(n), np.array([0, 1, 1, 2, 2, 2]), np.array([3, 3])),            # repeats, nothing shared
             (np.zeros(n), np.array([0, 1, 2, 3]), np.array([3, 4])),                   # voxel 3 crossed and hit
             (np.full(n, m["l_max"] - 0.1), np.array([5]), np.array([0, 1, 2])),          # hits at the upper clamp
             (np.full(n, m["l_min"] + 0.1), np.array([0, 1, 2]), np.array([6]))]          # misses at the lower clamp
    for _ in range(n_random):
        cases.append((rng.uniform(m["l_min"], m["l_max"], n) * (rng.random(n) < 0.7),
                      rng.integers(0, n, int(rng.integers(1, 15))), rng.integers(0, n, int(rng.integers(1, 6)))))
    for log_odds, crossed, hit in cases:
        got = _call(fn, log_odds.copy(), crossed.copy(), hit.copy(), m["l_hit"], m["l_miss"], m["l_min"], m["l_max"])
        got = _as_array(got, log_odds.shape, "octomap_update")
        variants = _octomap_variants(log_odds, crossed, hit, **m)
        if np.allclose(got, variants["right"], atol=1e-9):
            continue
        where = f"for log_odds {np.round(log_odds, 2)}, crossed {crossed.tolist()}, hit {hit.tolist()}"
        for name, value in variants.items():
            if name != "right" and np.allclose(got, value, atol=1e-9):
                raise AssertionError(f"{where}: {_OCTOMAP_HINTS[name]}")
        raise AssertionError(f"{where}: got {np.round(got, 3)}, expected {np.round(variants['right'], 3)}")
    print(f"octomap_update: correct on {len(cases)} scans")
    return True


# --------------------------------------------------------------------------------------------------
# STE's region-of-interest score of one ray (ExplicitMap.roi_scores)
# --------------------------------------------------------------------------------------------------
FREE, UNKNOWN, OCCUPIED, OUTSIDE = 0, 1, 2, -1  # the voxel states along a ray, as the exercise gives them


def _roi_variants(state: np.ndarray, distance: np.ndarray, max_distance: float) -> dict[str, float]:
    """The right score of a ray and what plausible mistakes give."""
    inside = state != OUTSIDE
    occupied = state == OCCUPIED
    before = np.cumsum(occupied) - occupied == 0  # up to and including the first occupied voxel
    bonus = 0.5 * (max_distance - distance) / max_distance
    unknown = (state == UNKNOWN) & inside
    value = np.where(unknown, 0.5 + np.maximum(0.0, bonus), 0.0)
    n_inside = max(1, int(inside.sum()))
    return {
        "right": float((value * before).sum() / n_inside),
        "through_surfaces": float(value.sum() / n_inside),
        "per_counted": float((value * before).sum() / max(1, int((before & inside).sum()))),
        "unnormalised": float((value * before).sum()),
        "negative_bonus": float((np.where(unknown, 0.5 + bonus, 0.0) * before).sum() / n_inside),
        "no_bonus": float((np.where(unknown, 0.5, 0.0) * before).sum() / n_inside),
    }


_ROI_HINTS = {
    "through_surfaces": "the ray stops at the first occupied voxel: unknown voxels behind a surface cannot be seen",
    "per_counted": ("divide by the number of the ray's samples inside the grid (state != OUTSIDE), not by the number "
                    "counted before the surface: a ray blocked early should score less"),
    "unnormalised": "normalise the ray's sum by its number of samples inside the grid (rays differ in length)",
    "negative_bonus": ("the bonus is 0.5 (D - d) / D only within D voxels of a target; farther away it is 0, never "
                       "negative (use max(0, ...))"),
    "no_bonus": "an unknown voxel near a target scores more: 0.5 + max(0, 0.5 (D - d) / D), with d its distance in voxels",
}


def _roi_reference(state, distance, max_distance):
    return _roi_variants(np.asarray(state), np.asarray(distance, np.float64), max_distance)["right"]


def _random_ray(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """States along a ray (outside the grid at both ends, a surface somewhere or none) and distances to the nearest
    target voxel (some beyond the bonus range)."""
    n = int(rng.integers(12, 40))
    state = rng.choice([FREE, UNKNOWN, UNKNOWN, OCCUPIED], size=n, p=[0.35, 0.3, 0.3, 0.05])
    state[: int(rng.integers(0, 4))] = OUTSIDE
    if rng.random() < 0.8:
        state[int(rng.integers(n // 3, n))] = OCCUPIED
    state[n - int(rng.integers(0, 3)):] = OUTSIDE
    return state, rng.uniform(0.0, 20.0, size=n)


@compares_with(_roi_reference)
def check_ray_roi_score(ray_roi_score, n_trials: int = 60, seed: int = 0) -> bool:
    """``ray_roi_score(state, distance, max_distance)``: ``state`` (S,) the voxels a ray passes, in order (FREE 0,
    UNKNOWN 1, OCCUPIED 2, OUTSIDE -1 for a sample outside the grid), ``distance`` (S,) each voxel's distance to the
    nearest target voxel in voxels; returns the ray's ROI score: over the voxels up to and including the first
    occupied one, each unknown voxel scores 0.5 + max(0, 0.5 (D - d) / D), the sum divided by the number of samples
    inside the grid."""
    rng = np.random.default_rng(seed)
    for _ in range(n_trials):
        state, distance = _random_ray(rng)
        max_distance = float(rng.choice([5.0, 10.0]))
        got = float(_call(ray_roi_score, state.copy(), distance.copy(), max_distance))
        variants = _roi_variants(state, distance, max_distance)
        if np.isclose(got, variants["right"], rtol=1e-9, atol=1e-12):
            continue
        hint = next((h for name, h in _ROI_HINTS.items() if np.isclose(got, variants[name], rtol=1e-9, atol=1e-12)),
                    "sum the unknown voxels' scores up to the first occupied voxel, then divide by the in-grid samples")
        raise AssertionError(f"ray_roi_score is wrong for the ray\nstate    {state.tolist()}\ndistance "
                             f"{np.round(distance, 1).tolist()}\nmax_distance {max_distance}: you returned {got:.5f}, "
                             f"expected {variants['right']:.5f}\nHint: {hint}")
    print(f"check_ray_roi_score: {n_trials} random rays agree")
    return True
