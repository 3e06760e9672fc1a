"""Checkers for the exercises of notebook 02 (the voxel occupancy field).

Each ``check_*`` takes the learner's function, calls it on seeded random inputs (and a few hand-picked
edge cases), compares the answers with an independent computation written here in plain numpy, and
raises ``AssertionError`` with a hint when they differ. Where a wrong answer matches a common mistake
(an inclusive instead of exclusive product, cell-centred instead of corner-aligned vertices, a missing
white background, ...) the hint names that mistake. On success a checker prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np

from ..lattice import CUBE_BOUND
from .common import as_array as _as_array, call as _call, compares_with

_ATOL = 1e-6


def _pair(out, what: str):
    if out is None:
        raise AssertionError(f"{what} returned None: fill in the function body (it still looks like the stub)")
    if not isinstance(out, tuple) or len(out) != 2:
        raise AssertionError(f"{what} must return a tuple of two arrays")
    return out


def _close(a, b, atol: float = _ATOL) -> bool:
    return bool(np.allclose(a, b, atol=atol, rtol=1e-7))


def _random_occupancies(rng: np.random.Generator, rays: int, samples: int) -> np.ndarray:
    """Occupancies in [0, 1] with exact zeros and ones mixed in, so that edge cases occur."""
    occ = rng.uniform(0.0, 1.0, size=(rays, samples)) ** rng.uniform(0.5, 4.0, size=(rays, 1))
    occ[rng.uniform(size=occ.shape) < 0.1] = 0.0
    occ[rng.uniform(size=occ.shape) < 0.02] = 1.0
    return occ


# --------------------------------------------------------------------------------------------------
# Exercise 1: transmittance and weights from occupancies (Eq. 5)
# --------------------------------------------------------------------------------------------------
def _weights_reference(occ: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    transmittance = np.ones_like(occ)
    for i in range(1, occ.shape[1]):
        transmittance[:, i] = transmittance[:, i - 1] * (1.0 - occ[:, i - 1])
    return transmittance, occ * transmittance


def _weights_hint(occ, T, w) -> str:
    want_T, want_w = _weights_reference(occ)
    inclusive = np.cumprod(1.0 - occ, axis=1)
    if _close(T, inclusive):
        return ("your transmittance is the INCLUSIVE product prod_{j<=i} (1 - o_j): T_i must stop before sample i "
                "(T_1 = 1, the ray always reaches its first sample)")
    if _close(T, np.cumprod(occ, axis=1)) or _close(T, np.cumprod(np.c_[np.ones(len(occ)), occ[:, :-1]], axis=1)):
        return "the transmittance multiplies (1 - o_j), the probability of passing sample j, not o_j"
    if _close(T, want_T) and _close(w, want_T):
        return "the weight is w_i = o_i * T_i: you forgot the factor o_i"
    if _close(T, want_T) and _close(w, (1.0 - occ) * want_T):
        return "the weight is w_i = o_i * T_i (stopped AT sample i), not (1 - o_i) * T_i"
    if _close(T, want_w) and _close(w, want_T):
        return "you returned (weights, transmittance): return (transmittance, weights)"
    if _close(T, want_T):
        return "the transmittance is right; the weight is w_i = o_i * T_i"
    return "T_i = prod_{j<i} (1 - o_j) (an exclusive cumulative product, T_1 = 1) and w_i = o_i * T_i"


@compares_with(_weights_reference)
def check_transmittance_and_weights(transmittance_and_weights, n_trials: int = 20, seed: int = 0) -> bool:
    """``transmittance_and_weights(occ)`` takes occupancies (R, S) in [0, 1] (R rays, S samples each, in
    order along the ray) and returns ``(T, w)``, both (R, S): T_i = prod_{j<i} (1 - o_j), w_i = o_i T_i."""
    rng = np.random.default_rng(seed)
    cases = [np.array([[0.0, 0.0, 1.0, 0.5]]), np.array([[0.3, 0.3, 0.3, 0.3, 0.3]]), np.zeros((2, 3))]
    for _ in range(n_trials):
        cases.append(_random_occupancies(rng, int(rng.integers(1, 20)), int(rng.integers(2, 60))))
    for occ in cases:
        T, w = _pair(_call(transmittance_and_weights, occ.copy()), "transmittance_and_weights(occ)")
        T = _as_array(T, occ.shape, "transmittance_and_weights(occ)[0] (T)")
        w = _as_array(w, occ.shape, "transmittance_and_weights(occ)[1] (w)")
        want_T, want_w = _weights_reference(occ)
        if _close(T, want_T) and _close(w, want_w):
            continue
        r = int(np.argmax(np.abs(T - want_T).sum(axis=1) + np.abs(w - want_w).sum(axis=1)))
        raise AssertionError(
            f"transmittance_and_weights is wrong for the ray with occupancies {np.round(occ[r, :6], 3)}...:\n"
            f"T = {np.round(T[r, :6], 4)}..., expected {np.round(want_T[r, :6], 4)}...\n"
            f"w = {np.round(w[r, :6], 4)}..., expected {np.round(want_w[r, :6], 4)}...\n"
            f"Hint: {_weights_hint(occ, T, w)}"
        )
    print(f"check_transmittance_and_weights: {len(cases)} batches of rays agree (including o = 0 and o = 1)")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 2: the 8 vertices and trilinear weights of a point in the grid
# --------------------------------------------------------------------------------------------------
def _corners_and_weights_reference(point, bound: float, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """The (8, 3) vertex indices (i, j, k) of the cell holding ``point`` and their (8,) trilinear weights."""
    r = resolution
    p = (np.clip(np.asarray(point, dtype=np.float64), -bound, bound) + bound) / (2 * bound) * (r - 1)
    i0 = np.clip(np.floor(p), 0, r - 2).astype(int)
    f = p - i0
    offsets = np.array(list(np.ndindex(2, 2, 2)))
    return i0 + offsets, np.prod(np.where(offsets == 1, f, 1.0 - f), axis=1)


def _corners_reference(point: np.ndarray, bound: float, resolution: int) -> np.ndarray:
    """Dense (R, R, R) array indexed [i, j, k] holding each vertex's trilinear weight for ``point``."""
    dense = np.zeros((resolution,) * 3)
    corners, weights = _corners_and_weights_reference(point, bound, resolution)
    np.add.at(dense, tuple(corners.T), weights)
    return dense


def _corners_dense(corners, weights, resolution: int, what: str) -> np.ndarray:
    corners = np.asarray(corners)
    weights = _as_array(weights, (8,), f"{what}[1] (weights)")
    if corners.shape != (8, 3):
        raise AssertionError(f"{what}[0] (corners) has shape {corners.shape}, expected (8, 3)")
    if not np.issubdtype(corners.dtype, np.integer):
        if not np.allclose(corners, np.round(corners)):
            raise AssertionError(f"{what}[0] (corners) must hold integer vertex indices (i, j, k)")
        corners = np.round(corners).astype(int)
    if corners.min() < 0 or corners.max() >= resolution:
        bad = corners[(corners < 0).any(axis=1) | (corners >= resolution).any(axis=1)][0]
        raise AssertionError(
            f"{what} returned the vertex {bad}, outside the grid (indices run from 0 to R - 1 = {resolution - 1})\n"
            "Hint: a point on the upper face (x = +bound) lies in the LAST cell: clamp the lower corner to R - 2"
        )
    dense = np.zeros((resolution,) * 3)
    np.add.at(dense, tuple(corners.T), weights)
    return dense


def _corners_hint(point, bound, resolution, dense) -> str:
    r = resolution
    if abs(dense.sum() - 1.0) > 1e-6:
        return f"the 8 weights must sum to 1 (yours sum to {dense.sum():.4f})"
    # cell-centred vertices: vertex i at -bound + (i + 0.5) * 2 bound / R
    p = (np.clip(point, -bound, bound) + bound) / (2 * bound) * r - 0.5
    i0 = np.clip(np.floor(p), 0, r - 2).astype(int)
    f = np.clip(p - i0, 0.0, 1.0)
    cell = np.zeros_like(dense)
    for corner in np.ndindex(2, 2, 2):
        c = np.array(corner)
        cell[tuple(i0 + c)] += np.prod(np.where(c == 1, f, 1.0 - f))
    if _close(dense, cell):
        return ("the vertices sit ON the cube's corners (align_corners=True): vertex i is at -bound + i * 2 bound / (R - 1), "
                "so the spacing is 2 bound / (R - 1), not 2 bound / R with vertices at cell centres")
    want = _corners_reference(point, bound, resolution)
    flipped = np.zeros_like(dense)
    pr = (np.clip(point, -bound, bound) + bound) / (2 * bound) * (r - 1)
    i0 = np.clip(np.floor(pr), 0, r - 2).astype(int)
    f = pr - i0
    for corner in np.ndindex(2, 2, 2):
        c = np.array(corner)
        flipped[tuple(i0 + c)] += np.prod(np.where(c == 1, 1.0 - f, f))
    if _close(dense, flipped):
        return "the weights are swapped: the corner at offset 1 along an axis gets weight f (the fraction), the corner at offset 0 gets 1 - f"
    if _close(np.transpose(dense, (2, 1, 0)), want):
        return "the axes are reversed: return corners as (i, j, k) = (x index, y index, z index)"
    return ("p = (x + bound) / (2 bound) * (R - 1); lower corner i0 = floor(p) clamped to [0, R - 2]; f = p - i0; "
            "corner i0 + c (c in {0,1}^3) gets weight prod over axes of (f if c = 1 else 1 - f)")


@compares_with(_corners_and_weights_reference)
def check_trilinear_corners(trilinear_corners, n_trials: int = 200, seed: int = 0) -> bool:
    """``trilinear_corners(point, bound, resolution)`` takes a point (3,) inside the cube [-bound, bound]^3
    of a grid with R = ``resolution`` vertices per axis ON the cube's corners (vertex i at
    x = -bound + i * 2 bound / (R - 1)) and returns ``(corners, weights)``: the (8, 3) integer indices
    (i, j, k) of the vertices of the cell holding the point and their (8,) trilinear weights, in any order.
    A point on the upper face belongs to the last cell (lower corner R - 2)."""
    rng = np.random.default_rng(seed)
    cases = [
        (np.full(3, CUBE_BOUND), CUBE_BOUND, 5),  # the upper corner: last cell
        (np.full(3, -CUBE_BOUND), CUBE_BOUND, 5),
        (np.zeros(3), CUBE_BOUND, 5),  # a vertex (R odd)
        (np.array([0.3, -0.7, 0.9]), 1.0, 4),
    ]
    for _ in range(n_trials):
        bound = float(rng.uniform(0.5, 2.0))
        cases.append((rng.uniform(-bound, bound, size=3), bound, int(rng.integers(2, 12))))
    for point, bound, r in cases:
        out = _pair(_call(trilinear_corners, point.copy(), bound, r), "trilinear_corners(point, bound, resolution)")
        dense = _corners_dense(out[0], out[1], r, "trilinear_corners(...)")
        want = _corners_reference(point, bound, r)
        if _close(dense, want):
            continue
        got_idx, want_idx = np.argwhere(np.abs(dense) > 1e-12), np.argwhere(want > 1e-12)
        raise AssertionError(
            f"trilinear_corners is wrong for point {np.round(point, 4)}, bound {bound:.3f}, R = {r}:\n"
            f"your non-zero vertices {got_idx.tolist()} with weights {np.round(dense[tuple(got_idx.T)], 4).tolist()}\n"
            f"expected vertices {want_idx.tolist()} with weights {np.round(want[tuple(want_idx.T)], 4).tolist()}\n"
            f"Hint: {_corners_hint(point, bound, r, dense)}"
        )
    print(f"check_trilinear_corners: {len(cases)} points agree (including the cube's corners and a vertex)")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 3: compositing colour and depth, with the white background
# --------------------------------------------------------------------------------------------------
def _composite_reference(weights, t, colours):
    acc = weights.sum(axis=1)
    rgb = (weights[..., None] * colours).sum(axis=1) + (1.0 - acc)[:, None]
    return rgb, (weights * t).sum(axis=1)


def _composite_hint(weights, t, colours, rgb, depth) -> str:
    want_rgb, want_depth = _composite_reference(weights, t, colours)
    acc = weights.sum(axis=1)
    if _close(rgb, want_rgb - (1.0 - acc)[:, None]):
        return "the part of the ray that hits nothing (1 - sum w) shows the white background: add (1 - sum_i w_i) to each channel"
    if _close(rgb, want_rgb) and _close(depth, want_depth / np.maximum(acc, 1e-12)):
        return ("do not divide the depth by sum w: a ray that hits nothing must render depth 0, like the measurement "
                "(the paper's D = sum_i w_i d_i)")
    if _close(rgb, want_rgb) and _close(depth, t.mean(axis=1)):
        return "the depth is the WEIGHTED sum sum_i w_i t_i, not the mean of the sample positions"
    if _close(rgb, want_rgb) and _close(depth, t[np.arange(len(t)), weights.argmax(axis=1)]):
        return "that is the depth of the heaviest sample; the rendered depth is the expectation sum_i w_i t_i"
    if _close(rgb, want_rgb):
        return "the colour is right; the depth is D = sum_i w_i t_i"
    return "C = sum_i w_i c_i + (1 - sum_i w_i) * white, D = sum_i w_i t_i"


@compares_with(_composite_reference)
def check_composite(composite, n_trials: int = 20, seed: int = 0) -> bool:
    """``composite(weights, t, colours)`` takes weights (R, S) (with sum_i w_i <= 1 per ray), sample depths
    t (R, S) and sample colours (R, S, 3) and returns ``(rgb, depth)``: rgb (R, 3) = sum_i w_i c_i plus
    the white background for the part of the ray that hits nothing, and depth (R,) = sum_i w_i t_i."""
    rng = np.random.default_rng(seed)
    for trial in range(n_trials):
        r, s = int(rng.integers(1, 20)), int(rng.integers(2, 50))
        occ = _random_occupancies(rng, r, s) * rng.uniform(0.0, 1.0, size=(r, 1))
        occ[0] = 0.0  # a ray that hits nothing
        _, weights = _weights_reference(occ)
        t = np.sort(rng.uniform(0.2, 3.5, size=(r, s)), axis=1)
        colours = rng.uniform(0.0, 1.0, size=(r, s, 3))
        out = _pair(_call(composite, weights.copy(), t.copy(), colours.copy()), "composite(weights, t, colours)")
        rgb = _as_array(out[0], (r, 3), "composite(...)[0] (rgb)")
        depth = _as_array(out[1], (r,), "composite(...)[1] (depth)")
        want_rgb, want_depth = _composite_reference(weights, t, colours)
        if _close(rgb, want_rgb) and _close(depth, want_depth):
            continue
        i = int(np.argmax(np.abs(rgb - want_rgb).sum(axis=1) + np.abs(depth - want_depth)))
        raise AssertionError(
            f"composite is wrong for ray {i} (accumulated weight {weights[i].sum():.3f}): "
            f"rgb {np.round(rgb[i], 4)}, depth {depth[i]:.4f}; expected rgb {np.round(want_rgb[i], 4)}, depth {want_depth[i]:.4f}\n"
            f"Hint: {_composite_hint(weights, t, colours, rgb, depth)}"
        )
    print(f"check_composite: {n_trials} batches of rays agree (each with one ray that hits nothing)")
    return True
