"""Checkers for the exercises of notebook 04 (entropy along rays, the semantic-targeted utility, the two-stage search).

Each ``check_*`` takes the learner's function, calls it on several seeded random inputs, compares
the answers with an independent computation written here in plain numpy, and raises
``AssertionError`` with a hint when they differ. Where a wrong answer matches a common mistake
(an un-weighted entropy sum, inclusive transmittance, bits instead of nats, a convex mix of the two
scores, resampling around views that can never be chosen, ...) the hint names that mistake. On success a checker prints
one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np

from ..classes import NUM_CLASSES
from ..geometry import TOP_VIEW, angular_distance, fibonacci_hemisphere
from ..planners import far_enough
from .common import as_array as _as_array, call as _call, compares_with

_ATOL = 1e-6


def _close(a, b, atol: float = _ATOL) -> bool:
    return bool(np.allclose(a, b, atol=atol, rtol=1e-6))


def _entropy(o: np.ndarray, log=np.log) -> np.ndarray:
    """Bernoulli entropy with 0 log 0 = 0."""
    o = np.clip(o, 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(o > 0, o * log(np.where(o > 0, o, 1.0)), 0.0)
        b = np.where(o < 1, (1 - o) * log(np.where(o < 1, 1 - o, 1.0)), 0.0)
    return -(a + b)


# --------------------------------------------------------------------------------------------------
# Exercise 1: the entropy of a ray (Eqs. 10-11)
# --------------------------------------------------------------------------------------------------
def _random_occupancies(rng: np.random.Generator, n_rays: int, n_samples: int) -> np.ndarray:
    """Rays with free space, uncertain bands and (sometimes) an opaque surface, some exact 0s and 1s."""
    occ = rng.uniform(0.0, 1.0, size=(n_rays, n_samples)) * (rng.uniform(size=(n_rays, n_samples)) < 0.6)
    occ[rng.uniform(size=(n_rays, n_samples)) < 0.1] = 0.0
    surface = rng.integers(1, n_samples, size=n_rays)
    opaque = rng.uniform(size=n_rays) < 0.4
    occ[opaque, surface[opaque]] = 1.0
    return occ


def _ray_entropy_reference(occ: np.ndarray) -> np.ndarray:
    transmittance = np.cumprod(np.concatenate([np.ones_like(occ[:, :1]), 1.0 - occ[:, :-1]], axis=1), axis=1)
    return (transmittance * _entropy(occ)).sum(axis=1)


@compares_with(_ray_entropy_reference)
def check_ray_entropy(ray_entropy, n_trials: int = 20, seed: int = 0) -> bool:
    """``ray_entropy(occ)`` takes occupancies ``(R, N)`` (numpy, samples ordered from the camera outwards)
    and returns H_ray ``(R,)`` in nats: sum_i T_i H(o_i) with T_i = prod_{j<i} (1 - o_j) (Eq. 11)."""
    rng = np.random.default_rng(seed)
    for trial in range(n_trials):
        n_rays, n_samples = int(rng.integers(3, 12)), int(rng.integers(4, 40))
        occ = _random_occupancies(rng, n_rays, n_samples)
        got = _as_array(_call(ray_entropy, occ.copy()), (n_rays,), f"ray_entropy(occ of shape {occ.shape})")
        if not np.all(np.isfinite(got)):
            raise AssertionError("ray_entropy returned NaN or inf: at o = 0 and o = 1 the entropy is 0 (0 ln 0 = 0); "
                                 "clip or use a where() before the log\nHint: np.where(o > 0, o * np.log(o), 0) per term")
        want = _ray_entropy_reference(occ)
        if _close(got, want):
            continue
        h = _entropy(occ)
        transmittance = np.cumprod(np.concatenate([np.ones_like(occ[:, :1]), 1.0 - occ[:, :-1]], axis=1), axis=1)
        if _close(got, h.sum(axis=1)):
            hint = ("you summed H(o_i) without weighting: samples behind an opaque surface cannot be seen, "
                    "multiply each H(o_i) by its transmittance T_i")
        elif _close(got, (np.cumprod(1.0 - occ, axis=1) * h).sum(axis=1)):
            hint = "the transmittance is exclusive: T_i = prod over j < i (the sample itself is not in the product; T_1 = 1)"
        elif _close(got, want / np.log(2.0)) or _close(got, _ray_entropy_reference_log(occ, np.log2)):
            hint = "that is in bits: the paper's Eq. 10 uses the natural log (nats)"
        elif _close(got, (occ * transmittance * h).sum(axis=1)):
            hint = "you weighted by w_i = o_i T_i (the rendering weight): Eq. 11 weights by the transmittance T_i alone"
        elif _close(got, h.mean(axis=1)) or _close(got, want / n_samples):
            hint = "Eq. 11 is a sum over the samples, not a mean"
        elif np.allclose(got, want, atol=1e-3):
            hint = ("close but not exact: clipping o to [eps, 1 - eps] before the log gives o = 0 and o = 1 a small "
                    "entropy instead of exactly 0; let those terms be 0 (np.where, or scipy.special.xlogy)")
        else:
            hint = ("compare with Eqs. 10-11 term by term on a ray of two samples, e.g. o = (0.5, 0.5): the entropy of each "
                    "sample in nats, and the chance that the ray reaches it")
        i = int(np.argmax(np.abs(got - want)))
        raise AssertionError(f"ray_entropy is wrong: ray {i} with occupancies {np.round(occ[i], 3)} gave {got[i]:.6f}, "
                             f"expected {want[i]:.6f}\nHint: {hint}")
    print(f"check_ray_entropy: {n_trials} random sets of rays agree (opaque surfaces, exact 0s and 1s included)")
    return True


def _ray_entropy_reference_log(occ, log):
    transmittance = np.cumprod(np.concatenate([np.ones_like(occ[:, :1]), 1.0 - occ[:, :-1]], axis=1), axis=1)
    return (transmittance * _entropy(occ, log)).sum(axis=1)


# --------------------------------------------------------------------------------------------------
# Exercise 2: the utility of views from their H_ray maps and rendered labels (Eqs. 12-15)
# --------------------------------------------------------------------------------------------------
def _utility_reference(h, labels, targets, epsilon):
    mask = np.isin(labels, targets)
    u_er = h.sum(axis=(1, 2))
    u_et = (h * mask).sum(axis=(1, 2))
    return u_et + epsilon * u_er, u_et, u_er


def _utility_only_reference(h_ray, labels, targets, epsilon):
    return _utility_reference(h_ray, labels, targets, epsilon)[0]


@compares_with(_utility_only_reference)
def check_utility(utility, n_trials: int = 20, seed: int = 0) -> bool:
    """``utility(h_ray, labels, targets, epsilon)`` takes per-ray entropies ``(V, H, W)``, rendered class
    labels ``(V, H, W)`` (the argmax of S), a tuple of target ids and epsilon >= 0, and returns U ``(V,)``:
    U = U_et + epsilon U_er, U_er = sum of all H_ray, U_et = sum of H_ray over rays labelled a target."""
    rng = np.random.default_rng(seed)
    for trial in range(n_trials):
        v, hh, ww = int(rng.integers(2, 6)), int(rng.integers(3, 9)), int(rng.integers(3, 9))
        h = rng.exponential(1.0, size=(v, hh, ww))
        labels = rng.integers(0, NUM_CLASSES, size=(v, hh, ww))
        targets = tuple(sorted(rng.choice(np.arange(1, NUM_CLASSES), size=int(rng.integers(1, 3)), replace=False).tolist()))
        epsilon = float([0.2, 0.5, 0.0, rng.uniform(0.05, 3.0)][trial % 4])
        got = _as_array(_call(utility, h.copy(), labels.copy(), targets, epsilon), (v,),
                        f"utility(h_ray {h.shape}, labels, {targets}, {epsilon})")
        want, u_et, u_er = _utility_reference(h, labels, targets, epsilon)
        if _close(got, want):
            continue
        n = hh * ww
        if _close(got, (1 - epsilon) * u_et + epsilon * u_er):
            hint = ("that is a convex mix (1 - eps) U_et + eps U_er (the same as U_et + eps * [sum over NON-target rays]): "
                    "Eq. 15 is U_et + eps U_er, and U_er sums over ALL rays, target rays included")
        elif len(targets) > 1 and _close(got, _utility_reference(h, labels, targets[:1], epsilon)[0]):
            hint = "with several target classes a ray counts if its label is ANY of them: np.isin(labels, targets)"
        elif _close(got, u_et) or _close(got, u_er):
            hint = "you returned one of the two scores alone: U = U_et + eps U_er"
        elif _close(got, epsilon * u_et + u_er):
            hint = "epsilon weighs the exploration score U_er, not the exploitation score U_et"
        elif _close(got, want / n):
            hint = "Eqs. 12-13 sum over the rays: use sums, not means"
        elif _close(got, _utility_reference(h, labels, tuple(c for c in range(NUM_CLASSES) if c not in targets), epsilon)[0]):
            hint = "the mask is inverted: U_et counts the rays whose label IS a target"
        else:
            hint = ("compare with Eqs. 12-15 on one view of two rays, one labelled a target: which rays each term sums, and how "
                    "epsilon combines them")
        raise AssertionError(f"utility is wrong for targets {targets}, epsilon {epsilon:.3g}: got {np.round(got, 4)}, "
                             f"expected {np.round(want, 4)}\nHint: {hint}")
    print(f"check_utility: {n_trials} random sets of views agree")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 3: the two-stage candidate search (Sec. III-C)
# --------------------------------------------------------------------------------------------------
def _best_allowed_first(uniform, score, visited, top_k) -> list[int]:
    """The indices of the ``top_k`` best first-stage views that are far enough from the visited ones, best first."""
    first, allowed = np.asarray(score(uniform), dtype=float), far_enough(uniform, visited)
    return [i for i in np.argsort(-first, kind="stable") if allowed[i]][:top_k]


def _search_variants(score, visited, azimuth_offset, resample, n_uniform, top_k) -> dict[str, tuple]:
    """(sorted candidates, best view) of the right search and of the mistakes in ``_SEARCH_HINTS``."""
    uniform = fibonacci_hemisphere(n_uniform, azimuth_offset=azimuth_offset)
    first = np.asarray(score(uniform), dtype=float)
    allowed = far_enough(uniform, visited)
    by_value = np.argsort(-first, kind="stable")

    def search(centres, best_among_uniform=True, skip_visited=True):
        resampled = np.concatenate([resample(uniform[i]) for i in centres]) if len(centres) else np.zeros((0, 2))
        candidates = np.concatenate([uniform, resampled]) if best_among_uniform else resampled
        values = np.asarray(score(candidates), dtype=float)
        ok = far_enough(candidates, visited) if skip_visited else np.ones(len(candidates), bool)
        return _sorted_views(np.concatenate([uniform, resampled])), candidates[int(np.argmax(np.where(ok, values, -np.inf)))]

    right = _best_allowed_first(uniform, score, visited, top_k)
    return {"right": search(right),
            "top_k_of_all": search(list(by_value[:top_k])),
            "lowest": search([i for i in by_value[::-1] if allowed[i]][:top_k]),
            "second_stage_only": search(right, best_among_uniform=False),
            "visited_allowed": search(right, skip_visited=False)}


def _sorted_views(views: np.ndarray) -> np.ndarray:
    """Views in a canonical order (rows sorted), so that two searches compare whatever order they drew in."""
    views = np.round(np.asarray(views, dtype=float), 9)
    return views[np.lexsort(views.T[::-1])] if len(views) else views


_SEARCH_HINTS = {
    "top_k_of_all": "resample around the top K of the ALLOWED first-stage views (far_enough): a view next to a "
                    "visited one can never be chosen, so its neighbourhood wastes the second stage",
    "lowest": "the top K are the K HIGHEST utilities of the first stage (sort descending)",
    "second_stage_only": "choose the best of ALL candidates, the first stage's included: a first-stage view can win",
    "visited_allowed": "the chosen view must be far_enough from every visited view, in both stages",
}


def _search_cases(rng: np.random.Generator):
    """Smooth synthetic utilities with two peaks; the top view visited, and in every other case also the best
    first-stage view (so that the top K must skip it); in some, the best view of all is a first-stage one."""
    cases = []
    for k in range(8):
        offset, n_uniform = float(rng.uniform(0, 2 * np.pi)), int(rng.choice([20, 40]))
        uniform = fibonacci_hemisphere(n_uniform, azimuth_offset=offset)
        peaks = np.c_[rng.uniform(0.1, 1.4, 2), rng.uniform(0, 2 * np.pi, 2)]
        if k % 4 == 0:  # the highest peak exactly on a first-stage view: its resampled neighbours are all lower
            peaks[0] = uniform[rng.choice(np.flatnonzero(uniform[:, 0] < 1.3))]
        weights = np.array([1.0, rng.uniform(0.3, 0.9)])
        score = (lambda peaks, weights: lambda views: (
            np.exp(4 * np.cos(angular_distance(np.asarray(views), peaks))) @ weights))(peaks, weights)
        offsets = np.array([[0.15, 0.0], [-0.15, 0.0], [0.0, 0.3], [0.0, -0.3]]) * (1 + 0.2 * (k % 3))

        def resample(view, offsets=offsets):  # deterministic neighbours: whatever order they are drawn in
            out = np.asarray(view, dtype=float)[None] + offsets
            out[:, 0] = np.clip(out[:, 0], 0.02, np.pi / 2)
            return out

        visited = np.array([TOP_VIEW, uniform[np.argmax(score(uniform))]]) if k % 2 else np.array([TOP_VIEW])
        cases.append((score, visited, offset, resample, n_uniform, int(rng.choice([3, 5]))))
    return cases


def _search_reference(score, visited, azimuth_offset, resample, n_uniform, top_k):
    uniform = fibonacci_hemisphere(n_uniform, azimuth_offset=azimuth_offset)
    centres = _best_allowed_first(uniform, score, visited, top_k)
    candidates = np.concatenate([uniform, *(resample(uniform[i]) for i in centres)])
    values = np.asarray(score(candidates), dtype=float)
    return candidates, values, int(np.argmax(np.where(far_enough(candidates, visited), values, -np.inf)))


@compares_with(_search_reference)
def check_two_stage_search(fn, seed: int = 0) -> bool:
    """``fn(score, visited, azimuth_offset, resample, n_uniform, top_k)`` -> ``(candidates, values, best)``: the
    ``n_uniform`` Fibonacci views turned by ``azimuth_offset`` and the views ``resample(view)`` returns around each of
    the ``top_k`` best allowed ones; ``score(views)`` of all of them; the index of the best allowed candidate."""
    rng = np.random.default_rng(seed)
    for score, visited, offset, resample, n_uniform, top_k in _search_cases(rng):
        got = _call(fn, score, visited.copy(), offset, resample, n_uniform, top_k)
        if not isinstance(got, tuple) or len(got) != 3:
            raise AssertionError(f"two_stage_search must return (candidates, values, best), got {type(got).__name__}")
        candidates, values, best = got
        n = n_uniform + top_k * len(resample(visited[0]))
        candidates = _as_array(candidates, (n, 2), "two_stage_search's candidates (N_uni + K x N_re views)")
        values = _as_array(values, (n,), "two_stage_search's values")
        if not _close(values, score(candidates)):
            raise AssertionError("values[i] must be score(candidates)[i]: score both stages' candidates")
        best_view = candidates[int(best)]
        variants = _search_variants(score, visited, offset, resample, n_uniform, top_k)
        right_set, right_best = variants["right"]
        if np.array_equal(_sorted_views(candidates), right_set) and _close(best_view, right_best):
            continue  # in any order: the candidates as a set and the chosen view
        where = f"(n_uniform {n_uniform}, top_k {top_k}, visited {np.round(visited, 3).tolist()})"
        for name, (views, chosen) in variants.items():
            if name != "right" and np.array_equal(_sorted_views(candidates), views) and _close(best_view, chosen):
                raise AssertionError(f"two_stage_search {where}: {_SEARCH_HINTS[name]}")
        if not np.array_equal(_sorted_views(candidates), right_set):
            raise AssertionError(f"two_stage_search {where}: the candidates are not the expected set (the chosen view "
                                 "may still be right): the first stage is fibonacci_hemisphere(n_uniform, "
                                 "azimuth_offset=...), the second resample(view) around each of the top K allowed "
                                 "first-stage views, taken from the first stage's own views in order of their scores")
        raise AssertionError(f"two_stage_search {where}: the candidates are right, but it chose {np.round(best_view, 3)}, "
                             f"expected {np.round(right_best, 3)}: the best allowed candidate of both stages")
    print("check_two_stage_search: 8 searches agree (candidates of both stages and the chosen view)")
    return True
