"""Checkers for the exercises of notebook 05 (the planning loop).

Each ``check_*`` takes the learner's function, calls it on seeded random inputs (plus a few built to
expose one mistake each), compares the answers with an independent computation written here in
plain numpy, and raises ``AssertionError`` with a hint when they differ. Where a wrong answer matches
a common mistake (distances in (elevation, azimuth) instead of between camera centres, the closest
visited view instead of the mean, 0-based step numbers, rectangles instead of trapezoids, ...) the
hint names it. On success a checker prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np

from ..planners import MIN_SEPARATION
from .common import call as _call, compares_with, diagnose

# --------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------
_RADIUS = 2.0  # the hemisphere radius of the camera centres (any radius gives the same choice)


def _centres(views: np.ndarray) -> np.ndarray:
    el, az = views[:, 0], views[:, 1]
    return _RADIUS * np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)


def _great_circle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    da, db = _centres(a) / _RADIUS, _centres(b) / _RADIUS
    return np.arccos(np.clip(da @ db.T, -1.0, 1.0))


def _choice(score: np.ndarray, allowed: np.ndarray) -> int:
    return int(np.argmax(np.where(allowed, score, -np.inf)))


# --------------------------------------------------------------------------------------------------
# Exercise 1: the Max View Distance planner's choice
# --------------------------------------------------------------------------------------------------
def _max_distance_variants(candidates, visited, min_separation) -> dict[str, int]:
    """The right choice and the choices a few plausible mistakes make (independent of stair_lite)."""
    c, v = _centres(candidates), _centres(visited)
    sq = ((c[:, None, :] - v[None, :, :]) ** 2).sum(-1)  # (N, M) squared distances between camera centres
    allowed = _great_circle(candidates, visited).min(axis=1) > min_separation
    d_el = candidates[:, None, 0] - visited[None, :, 0]
    d_az = candidates[:, None, 1] - visited[None, :, 1]
    flat = d_el ** 2 + d_az ** 2  # "distance" in the (elevation, azimuth) plane
    return {
        "right": _choice(sq.mean(axis=1), allowed),
        "flat": _choice(flat.mean(axis=1), allowed),
        "min": _choice(sq.min(axis=1), allowed),
        "not_squared": _choice(np.sqrt(sq).mean(axis=1), allowed),
        "no_exclusion": int(np.argmax(sq.mean(axis=1))),
    }


def _max_distance_cases(rng: np.random.Generator, n_random: int):
    """(candidates, visited) pairs: random ones, and hand-made ones where one mistake changes the answer."""
    cases = []
    # 1. the unconstrained best candidate sits 3 deg from a visited view: it must be excluded
    visited = np.array([[0.05, 0.0], [0.15, np.pi], [0.2, np.pi + 0.3], [0.25, np.pi - 0.3]])
    candidates = np.array([[0.05, np.radians(3.0)], [0.6, 0.5], [0.3, 1.2], [1.0, 4.0], [0.05, 0.4], [0.4, 5.8]])
    cases.append((candidates, visited))
    # 2. azimuths across the seam: 0.1 and 2 pi - 0.1 are neighbours on the sphere, far apart in (el, az)
    visited = np.array([[0.2, 0.1], [np.pi / 2, 0.0]])
    candidates = np.array([[0.2, 2 * np.pi - 0.3], [0.3, np.pi], [0.6, 2.0], [0.5, 4.0]])
    cases.append((candidates, visited))
    # 3. random missions in progress, like the planner's 200 random candidates against 1-9 visited views
    for _ in range(n_random):
        m = int(rng.integers(1, 10))
        sin_el = rng.uniform(0.005, 1.0, size=(m + 60,))
        views = np.stack([np.arcsin(sin_el), rng.uniform(0, 2 * np.pi, size=m + 60)], axis=1)
        visited, candidates = views[:m], views[m:]
        # a few candidates very close to visited views (they must never be chosen)
        near = visited[rng.integers(0, m, size=5)] + rng.normal(0, 0.03, size=(5, 2))
        near[:, 0] = np.clip(near[:, 0], 0.01, np.pi / 2)
        near[:, 1] %= 2 * np.pi
        cases.append((np.concatenate([candidates, near]), visited))
    return cases


_MAX_DISTANCE_HINTS = {
    "flat": "you measured distance in the (elevation, azimuth) plane: azimuth wraps around at 2 pi and means nothing "
            "at the top view; turn every view into its camera centre r (cos el cos az, cos el sin az, sin el) first",
    "min": "you scored a candidate by its CLOSEST visited view (min); the planner uses the MEAN squared distance "
           "to all visited camera centres",
    "not_squared": "you averaged plain distances; the planner averages SQUARED distances",
    "no_exclusion": "you chose a candidate within the minimum separation of a visited view: exclude candidates whose "
                    "great-circle angle to any visited view is <= min_separation before taking the best",
}


def _max_distance_reference(candidates, visited, min_separation):
    return _max_distance_variants(np.asarray(candidates), np.asarray(visited), min_separation)["right"]


@compares_with(_max_distance_reference)
def check_max_distance_choice(max_distance_choice, n_random: int = 60, seed: int = 0) -> bool:
    """``max_distance_choice(candidates, visited, min_separation)`` takes candidate views (N, 2) and visited
    views (M, 2) as (elevation, azimuth) in radians and a minimum separation in radians, and returns the
    index (an int) of the candidate whose camera centre has the largest MEAN SQUARED Euclidean distance
    to the visited camera centres, among candidates more than ``min_separation`` (great-circle angle)
    away from every visited view."""
    rng = np.random.default_rng(seed)
    cases = _max_distance_cases(rng, n_random)
    answers = []
    for candidates, visited in cases:
        got = _call(max_distance_choice, candidates.copy(), visited.copy(), MIN_SEPARATION)
        if got is None:
            raise AssertionError("max_distance_choice returned None: fill in the function body (it still looks like the stub)")
        if np.ndim(got) != 0 or not float(got).is_integer():
            raise AssertionError(f"max_distance_choice must return one integer index into the candidates, got {got!r}")
        if not 0 <= int(got) < len(candidates):
            raise AssertionError(f"max_distance_choice returned index {int(got)}, but there are {len(candidates)} candidates")
        answers.append(int(got))
    per_case = [_max_distance_variants(candidates, visited, MIN_SEPARATION) for candidates, visited in cases]
    variants = {name: [v[name] for v in per_case] for name in per_case[0]}
    wrong = [i for i, (got, want) in enumerate(zip(answers, variants["right"])) if got != want]
    if wrong:
        i = wrong[0]
        (candidates, visited), got, want = cases[i], answers[i], variants["right"][i]
        if _great_circle(candidates[got : got + 1], visited).min() <= MIN_SEPARATION:
            hint = _MAX_DISTANCE_HINTS["no_exclusion"]
        else:
            hint = diagnose(answers, variants, _MAX_DISTANCE_HINTS,
                            "score = mean over visited views of |c - v|^2 between camera centres; take the best "
                            "candidate among those more than min_separation from every visited view")
        raise AssertionError(
            f"max_distance_choice picked candidate {got} {np.round(candidates[got], 3)}, expected {want} "
            f"{np.round(candidates[want], 3)} (with {len(visited)} visited views)\nHint: {hint}")
    print(f"check_max_distance_choice: {len(cases)} planning situations agree (seam, exclusion and random cases)")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 2: summarising a mission's curve
# --------------------------------------------------------------------------------------------------
def fake_records(rng: np.random.Generator, n: int = 10) -> list[dict]:
    """Mission-like step records (step 1..n) with a rising, noisy PSNR and F1, for checkers and tests."""
    psnr = 14.0 + np.cumsum(rng.uniform(-0.5, 2.0, size=n))
    f1 = np.clip(np.cumsum(rng.uniform(-0.03, 0.15, size=n)), 0.0, 1.0)
    return [{"step": i + 1, "psnr": float(psnr[i]), "f1": float(f1[i])} for i in range(n)]


def _first_step_reference(records, key, threshold):
    for r in records:
        if r[key] > threshold:
            return r["step"]
    return None


def _area_reference(records, key):
    x = np.array([r["step"] for r in records], float)
    y = np.array([r[key] for r in records], float)
    return float(np.sum((y[1:] + y[:-1]) / 2 * np.diff(x)))


def _curve_cases(rng: np.random.Generator, n_random: int):
    """(records, key, threshold) triples, including ones built to expose a single mistake."""
    cases = []
    base = fake_records(np.random.default_rng(1), 10)
    cases.append((base, "f1", base[0]["f1"] - 1e-3))  # already exceeded at step 1 (index 0 is falsy!)
    cases.append((base, "f1", 2.0))  # never exceeded
    cases.append((base, "psnr", base[4]["psnr"]))  # equal at step 5 is not "exceeds"
    up_down = [dict(r) for r in base]
    for r, v in zip(up_down, [0.1, 0.2, 0.6, 0.3, 0.7, 0.8, 0.4, 0.9, 0.95, 0.97]):
        r["f1"] = v
    cases.append((up_down, "f1", 0.5))  # exceeds at step 3, falls back, exceeds again
    for _ in range(n_random):
        records = fake_records(rng, int(rng.integers(2, 16)))
        key = "psnr" if rng.uniform() < 0.5 else "f1"
        values = np.array([r[key] for r in records])
        threshold = float(rng.uniform(values.min() - 0.1 * np.ptp(values), values.max()))
        cases.append((records, key, threshold))
    return cases


@compares_with(_first_step_reference)
def check_first_step_above(first_step_above, n_random: int = 100, seed: int = 0) -> bool:
    """``first_step_above(records, key, threshold)`` returns the step number (the record's ``"step"``: the
    number of measurements taken, 1 for the top view) at which ``record[key]`` first EXCEEDS (>) the
    threshold, or None if it never does."""
    rng = np.random.default_rng(seed)
    cases = _curve_cases(rng, n_random)
    for records, key, threshold in cases:
        got = _call(first_step_above, [dict(r) for r in records], key, threshold)
        want = _first_step_reference(records, key, threshold)
        if got == want and (got is None) == (want is None):
            continue
        values = [round(r[key], 4) for r in records]
        where = (f"for {key} = {values} and threshold {threshold:.4f} you returned {got!r}, expected {want!r} "
                 "(steps count measurements from 1)")
        index = next((i for i, r in enumerate(records) if r[key] > threshold), None)
        last = next((r["step"] for r in reversed(records) if r[key] > threshold), None)
        at_least = next((r["step"] for r in records if r[key] >= threshold), None)
        tie = any(r[key] == threshold for r in records)
        if want is None and got is not None:
            hint = "the curve never exceeds the threshold: return None (not 0, -1 or the last step)"
        elif tie and got == at_least:
            hint = "'exceeds' means strictly greater (>): a value equal to the threshold does not count"
        elif index is not None and got == index:
            hint = ("off by one: you returned the list index (0-based); return the step number record['step'], "
                    "which counts measurements from 1")
        elif got == last:
            hint = "you returned the LAST step above the threshold; the question is the FIRST"
        elif got is None:
            hint = "the curve does exceed the threshold: return its first step (careful: step 1 is a valid answer)"
        else:
            hint = "walk the records in order and return record['step'] of the first with record[key] > threshold"
        raise AssertionError(f"first_step_above is wrong {where}\nHint: {hint}")
    print(f"check_first_step_above: {len(cases)} curves agree (including step 1, never, ties and dips)")
    return True


@compares_with(_area_reference)
def check_area_under_curve(area_under_curve, n_random: int = 100, seed: int = 0) -> bool:
    """``area_under_curve(records, key)`` returns the area under ``record[key]`` plotted against the step
    (the number of measurements), by the trapezoidal rule: sum over consecutive steps of
    (y_i + y_{i+1}) / 2 * (step_{i+1} - step_i)."""
    rng = np.random.default_rng(seed)
    cases = _curve_cases(rng, n_random)
    for records, key, _ in cases:
        got = _call(area_under_curve, [dict(r) for r in records], key)
        if got is None:
            raise AssertionError("area_under_curve returned None: fill in the function body (it still looks like the stub)")
        got = float(np.asarray(got).reshape(()))
        want = _area_reference(records, key)
        if abs(got - want) <= 1e-9 * max(1.0, abs(want)):
            continue
        y = np.array([r[key] for r in records], float)
        if abs(got - y.sum()) < 1e-9 * max(1.0, abs(want)):
            hint = "you summed the values (rectangles of width 1, one too many): use trapezoids between consecutive steps"
        elif abs(got - y[:-1].sum()) < 1e-9 * max(1.0, abs(want)) or abs(got - y[1:].sum()) < 1e-9 * max(1.0, abs(want)):
            hint = "left/right rectangles: use trapezoids, (y_i + y_{i+1}) / 2 per step interval"
        elif abs(got - y.mean()) < 1e-9 * max(1.0, abs(want)):
            hint = "that is the mean value, not the area: sum the trapezoids between consecutive steps"
        else:
            hint = "sum over i of (y_i + y_{i+1}) / 2 * (step_{i+1} - step_i)"
        raise AssertionError(f"area_under_curve is wrong for {key} over {len(records)} steps: got {got:.6f}, "
                             f"expected {want:.6f}\nHint: {hint}")
    print(f"check_area_under_curve: {len(cases)} curves agree")
    return True
