"""Checkers for the exercises of notebook 04 (entropy along rays, the semantic-targeted utility, picking a view).

Each ``check_*`` takes the learner's function, calls it on several seeded random inputs, compares
the answers with an independent computation written here in plain numpy, and raises
``AssertionError`` with a hint when they differ. Where a wrong answer matches a common mistake
(an un-weighted entropy sum, inclusive transmittance, bits instead of nats, a convex mix of the two
scores, ignoring the visited views, ...) the hint names that mistake. On success a checker prints
one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np

from ..classes import NUM_CLASSES
from .common import as_array as _as_array, call as _call, compares_with, diagnose

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
    """``ray_entropy(occ)`` takes occupancies ``(R, S)`` (numpy, samples ordered from the camera outwards)
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
            hint = "H(o) = -o ln o - (1 - o) ln(1 - o); T_i = prod_{j<i} (1 - o_j); H_ray = sum_i T_i H(o_i)"
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
            hint = "mask = np.isin(labels, targets); U_er = h.sum over the image; U_et = (h * mask).sum; U = U_et + eps U_er"
        raise AssertionError(f"utility is wrong for targets {targets}, epsilon {epsilon:.3g}: got {np.round(got, 4)}, "
                             f"expected {np.round(want, 4)}\nHint: {hint}")
    print(f"check_utility: {n_trials} random sets of views agree")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 3: the best candidate that is not too close to a visited view
# --------------------------------------------------------------------------------------------------
def _directions(views: np.ndarray) -> np.ndarray:
    el, az = views[:, 0], views[:, 1]
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)


def _best_reference(candidates, values, visited, min_separation):
    return _pick_variants(candidates, values, visited, min_separation)["right"]


def _pick_cases(rng: np.random.Generator):
    """Hand-made traps first (top view and azimuth seam), then random sets where the best view is visited."""
    sep = float(np.arccos(1.0 - 0.01))
    cases = []
    # near the top view: azimuths far apart, great-circle angle tiny -> must be rejected
    cases.append((np.array([[np.pi / 2, 0.0], [1.52, 3.0], [0.5, 0.4], [1.0, 2.0]]), np.array([10.0, 9.0, 5.0, 4.0]),
                  np.array([[np.pi / 2, 0.0]]), sep))
    # across the azimuth seam: (0.3, 0.02) and (0.3, 2 pi - 0.02) are almost the same view
    cases.append((np.array([[0.3, 2 * np.pi - 0.02], [0.8, 1.0], [0.2, 4.0]]), np.array([7.0, 6.0, 1.0]),
                  np.array([[np.pi / 2, 0.0], [0.3, 0.02]]), sep))
    # a candidate at an elevation/azimuth distance above the limit in radians but below it on the sphere
    cases.append((np.array([[1.4, 1.5], [1.4, 1.0], [0.6, 3.0]]), np.array([4.0, 3.0, 2.0]), np.array([[1.4, 1.5]]), 0.2))
    for _ in range(30):
        n, m = int(rng.integers(5, 40)), int(rng.integers(1, 5))
        visited = np.c_[rng.uniform(0, np.pi / 2, m), rng.uniform(0, 2 * np.pi, m)]
        candidates = np.c_[rng.uniform(0, np.pi / 2, n), rng.uniform(0, 2 * np.pi, n)]
        candidates[: m] = visited + rng.normal(0, 0.03, size=(m, 2))  # candidates right next to visited views
        candidates[:, 0] = np.clip(candidates[:, 0], 0.0, np.pi / 2)
        values = rng.uniform(0, 1, n)
        values[: m] += 1.0  # ... which have the highest values
        cases.append((candidates, values, visited, float(rng.choice([sep, 0.1, 0.3]))))
    return cases


_PICK_HINTS = {
    "flat": ("(elevation, azimuth) is not a flat plane (think of the top view and the azimuth seam): "
             "compare unit direction vectors, angle = arccos(d_c . d_v)"),
    "degrees": "the angles and min_separation are both in radians: do not convert the angles to degrees",
    "argmax": "you took the plain argmax: candidates within min_separation of a visited view must be skipped",
    "argmin": "the best candidate has the HIGHEST utility (argmax)",
}


def _pick_variants(candidates, values, visited, sep) -> dict[str, int]:
    """The right choice and the choices of the mistakes in ``_PICK_HINTS``."""
    angles = np.arccos(np.clip(_directions(candidates) @ _directions(visited).T, -1.0, 1.0)).min(axis=1)
    flat = np.sqrt(((candidates[:, None, :] - visited[None, :, :]) ** 2).sum(-1)).min(axis=1)
    best = lambda ok: int(np.argmax(np.where(ok, values, -np.inf)))
    return {"right": best(angles > sep), "flat": best(flat > sep), "degrees": best(np.degrees(angles) > sep),
            "argmax": int(np.argmax(values)), "argmin": int(np.argmin(np.where(angles > sep, values, np.inf)))}


@compares_with(_best_reference)
def check_pick_best(pick_best, seed: int = 0) -> bool:
    """``pick_best(candidates, values, visited, min_separation)`` takes candidate views ``(N, 2)`` and
    visited views ``(M, 2)`` as (elevation, azimuth) in radians, the candidates' utilities ``(N,)`` and an
    angle in radians; it returns the index of the highest-valued candidate whose great-circle angle to
    every visited view exceeds ``min_separation``."""
    rng = np.random.default_rng(seed)
    cases = _pick_cases(rng)
    answers = []
    for candidates, values, visited, sep in cases:
        got = _call(pick_best, candidates.copy(), values.copy(), visited.copy(), sep)
        if got is None:
            raise AssertionError("pick_best returned None: fill in the function body (it still looks like the stub)")
        try:
            answers.append(int(np.asarray(got).reshape(())))
        except (TypeError, ValueError):
            raise AssertionError(f"pick_best must return one integer index, got {got!r}") from None
    per_case = [_pick_variants(*case) for case in cases]
    variants = {name: [v[name] for v in per_case] for name in per_case[0]}
    wrong = [i for i, (got, want) in enumerate(zip(answers, variants["right"])) if got != want]
    if wrong:
        i = wrong[0]
        candidates, values, visited, sep = cases[i]
        got, want = answers[i], variants["right"][i]
        too_close = 0 <= got < len(values) and not (
            np.arccos(np.clip(_directions(candidates[got:got + 1]) @ _directions(visited).T, -1, 1)) > sep).all()
        fallback = ("your choice lies within min_separation of a visited view" if too_close else
                    "keep the candidates whose smallest angle to the visited views exceeds min_separation, then argmax")
        hint = diagnose(answers, variants, _PICK_HINTS, fallback)
        raise AssertionError(f"pick_best returned {got}, expected {want} (candidates\n{np.round(candidates, 3)}\n"
                             f"values {np.round(values, 3)}, visited {np.round(visited, 3).tolist()}, "
                             f"min_separation {sep:.4f} rad)\nHint: {hint}")
    print(f"check_pick_best: {len(cases)} candidate sets agree (top view and azimuth seam included)")
    return True
