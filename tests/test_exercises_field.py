"""The checkers of notebook 02's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest
import torch

from stair_lite.exercises.field import check_composite, check_trilinear_corners, check_transmittance_and_weights
from stair_lite.field import corner_indices_and_weights
from stair_lite.rendering import compositing_weights


# ---- exercise 1: transmittance and weights ------------------------------------------------------
def weights_ok(occ):
    T = np.cumprod(np.c_[np.ones(len(occ)), 1.0 - occ[:, :-1]], axis=1)
    return T, occ * T


def weights_stair_lite(occ):
    w, T = compositing_weights(torch.as_tensor(occ))
    return T.numpy(), w.numpy()


def weights_inclusive(occ):
    T = np.cumprod(1.0 - occ, axis=1)
    return T, occ * T


def weights_no_o(occ):
    T, _ = weights_ok(occ)
    return T, T


def weights_cumprod_o(occ):
    T = np.cumprod(np.c_[np.ones(len(occ)), occ[:, :-1]], axis=1)
    return T, occ * T


def weights_swapped(occ):
    T, w = weights_ok(occ)
    return w, T


def weights_stub(occ):
    return None


def test_transmittance_accepts_correct():
    assert check_transmittance_and_weights(weights_ok)
    assert check_transmittance_and_weights(weights_stair_lite)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (weights_inclusive, "INCLUSIVE"),
        (weights_no_o, "forgot the factor o_i"),
        (weights_cumprod_o, r"\(1 - o_j\)"),
        (weights_swapped, "you returned \\(weights, transmittance\\)"),
        (weights_stub, "None"),
    ],
)
def test_transmittance_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_transmittance_and_weights(wrong)


# ---- exercise 2: corners and trilinear weights --------------------------------------------------
def corners_ok(point, bound, r):
    p = (point + bound) / (2 * bound) * (r - 1)
    i0 = np.clip(np.floor(p), 0, r - 2).astype(int)
    f = p - i0
    offsets = np.array(list(np.ndindex(2, 2, 2)))
    return i0 + offsets, np.prod(np.where(offsets == 1, f, 1 - f), axis=1)


def corners_stair_lite(point, bound, r):
    index, weights = corner_indices_and_weights(torch.as_tensor(point / bound, dtype=torch.float64)[None], r)
    rows = index[0].numpy()
    return np.stack([rows % r, (rows // r) % r, rows // (r * r)], axis=1), weights[0].numpy()


def corners_cell_centred(point, bound, r):
    p = (point + bound) / (2 * bound) * r - 0.5
    i0 = np.clip(np.floor(p), 0, r - 2).astype(int)
    f = np.clip(p - i0, 0.0, 1.0)
    offsets = np.array(list(np.ndindex(2, 2, 2)))
    return i0 + offsets, np.prod(np.where(offsets == 1, f, 1 - f), axis=1)


def corners_swapped_weights(point, bound, r):
    corners, _ = corners_ok(point, bound, r)
    p = (point + bound) / (2 * bound) * (r - 1)
    f = p - np.clip(np.floor(p), 0, r - 2)
    offsets = corners - corners.min(axis=0)
    return corners, np.prod(np.where(offsets == 1, 1 - f, f), axis=1)


def corners_no_clamp(point, bound, r):
    p = (point + bound) / (2 * bound) * (r - 1)
    i0 = np.floor(p).astype(int)
    f = p - i0
    offsets = np.array(list(np.ndindex(2, 2, 2)))
    return i0 + offsets, np.prod(np.where(offsets == 1, f, 1 - f), axis=1)


def corners_zyx(point, bound, r):
    corners, w = corners_ok(point, bound, r)
    return corners[:, ::-1], w


def test_corners_accepts_correct():
    assert check_trilinear_corners(corners_ok)
    assert check_trilinear_corners(corners_stair_lite)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (corners_cell_centred, "ON the cube's corners"),
        (corners_swapped_weights, "swapped"),
        (corners_no_clamp, "upper face"),
        (corners_zyx, "axes are reversed"),
    ],
)
def test_corners_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_trilinear_corners(wrong)


# ---- exercise 3: compositing colour and depth ---------------------------------------------------
def composite_ok(weights, t, colours):
    acc = weights.sum(axis=1)
    return (weights[..., None] * colours).sum(axis=1) + (1 - acc)[:, None], (weights * t).sum(axis=1)


def composite_black_background(weights, t, colours):
    return (weights[..., None] * colours).sum(axis=1), (weights * t).sum(axis=1)


def composite_normalised_depth(weights, t, colours):
    rgb, _ = composite_ok(weights, t, colours)
    return rgb, (weights * t).sum(axis=1) / np.maximum(weights.sum(axis=1), 1e-12)


def composite_mean_depth(weights, t, colours):
    rgb, _ = composite_ok(weights, t, colours)
    return rgb, t.mean(axis=1)


def composite_argmax_depth(weights, t, colours):
    rgb, _ = composite_ok(weights, t, colours)
    return rgb, t[np.arange(len(t)), weights.argmax(axis=1)]


def test_composite_accepts_correct():
    assert check_composite(composite_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (composite_black_background, "white background"),
        (composite_normalised_depth, "do not divide"),
        (composite_mean_depth, "WEIGHTED"),
        (composite_argmax_depth, "heaviest"),
    ],
)
def test_composite_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_composite(wrong)


def stub_raising(*args):
    raise NotImplementedError


@pytest.mark.parametrize("checker", [check_transmittance_and_weights, check_trilinear_corners, check_composite])
def test_checkers_explain_an_untouched_stub(checker):
    with pytest.raises(AssertionError, match="NotImplementedError"):
        checker(stub_raising)
