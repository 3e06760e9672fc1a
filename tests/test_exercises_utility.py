"""The checkers of notebook 04's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest
import torch

from stair_lite.exercises.utility import check_pick_best, check_ray_entropy, check_utility
from stair_lite.geometry import angular_distance
from stair_lite.planners import far_enough
from stair_lite.rendering import compositing_weights
from stair_lite.utility import point_entropy


# ---- exercise 1: the entropy of a ray -----------------------------------------------------------
def _h(o, log=np.log):
    with np.errstate(divide="ignore", invalid="ignore"):
        return -(np.where(o > 0, o * log(np.where(o > 0, o, 1)), 0) + np.where(o < 1, (1 - o) * log(np.where(o < 1, 1 - o, 1)), 0))


def _t_exclusive(occ):
    return np.cumprod(np.c_[np.ones(len(occ)), 1 - occ[:, :-1]], axis=1)


def entropy_ok(occ):
    return (_t_exclusive(occ) * _h(occ)).sum(axis=1)


def entropy_library(occ):  # stair_lite's own pieces give the same answer
    o = torch.as_tensor(occ, dtype=torch.float64)
    _, t = compositing_weights(o)
    return (t * point_entropy(o)).sum(dim=1).numpy()


def entropy_unweighted(occ):
    return _h(occ).sum(axis=1)


def entropy_inclusive(occ):
    return (np.cumprod(1 - occ, axis=1) * _h(occ)).sum(axis=1)


def entropy_bits(occ):
    return (_t_exclusive(occ) * _h(occ, np.log2)).sum(axis=1)


def entropy_weights(occ):
    return (occ * _t_exclusive(occ) * _h(occ)).sum(axis=1)


def entropy_nan(occ):  # the textbook formula without care for 0 log 0
    with np.errstate(divide="ignore", invalid="ignore"):
        return (_t_exclusive(occ) * -(occ * np.log(occ) + (1 - occ) * np.log(1 - occ))).sum(axis=1)


def entropy_clipped(occ):  # the common guard against log(0): clip o away from 0 and 1
    o = np.clip(occ, 1e-6, 1 - 1e-6)
    return (_t_exclusive(occ) * -(o * np.log(o) + (1 - o) * np.log(1 - o))).sum(axis=1)


def entropy_stub(occ):
    raise NotImplementedError


@pytest.mark.parametrize("ok", [entropy_ok, entropy_library])
def test_ray_entropy_accepts_correct(ok):
    assert check_ray_entropy(ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [(entropy_unweighted, "without weighting"), (entropy_inclusive, "exclusive"), (entropy_bits, "bits"),
     (entropy_weights, "rendering weight"), (entropy_nan, "NaN"), (entropy_stub, "NotImplementedError"),
     (entropy_clipped, "clipping")],
)
def test_ray_entropy_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_ray_entropy(wrong)


# ---- exercise 2: the utility --------------------------------------------------------------------
def utility_ok(h, labels, targets, eps):
    mask = np.isin(labels, targets)
    return (h * mask).sum(axis=(1, 2)) + eps * h.sum(axis=(1, 2))


def utility_convex(h, labels, targets, eps):
    mask = np.isin(labels, targets)
    return (1 - eps) * (h * mask).sum(axis=(1, 2)) + eps * h.sum(axis=(1, 2))


def utility_non_target_rest(h, labels, targets, eps):  # the same as the convex mix
    mask = np.isin(labels, targets)
    return (h * mask).sum(axis=(1, 2)) + eps * (h * ~mask).sum(axis=(1, 2))


def utility_first_target_only(h, labels, targets, eps):
    mask = labels == targets[0]
    return (h * mask).sum(axis=(1, 2)) + eps * h.sum(axis=(1, 2))


def utility_eps_on_target(h, labels, targets, eps):
    mask = np.isin(labels, targets)
    return eps * (h * mask).sum(axis=(1, 2)) + h.sum(axis=(1, 2))


def utility_means(h, labels, targets, eps):
    return utility_ok(h, labels, targets, eps) / (h.shape[1] * h.shape[2])


def utility_inverted(h, labels, targets, eps):
    mask = ~np.isin(labels, targets)
    return (h * mask).sum(axis=(1, 2)) + eps * h.sum(axis=(1, 2))


def test_utility_accepts_correct():
    assert check_utility(utility_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [(utility_convex, "convex mix"), (utility_non_target_rest, "ALL rays"), (utility_first_target_only, "ANY of them"), (utility_eps_on_target, "epsilon weighs"),
     (utility_means, "not means"), (utility_inverted, "inverted")],
)
def test_utility_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_utility(wrong)


# ---- exercise 3: the best allowed candidate -----------------------------------------------------
def pick_ok(candidates, values, visited, sep):
    return int(np.argmax(np.where(far_enough(candidates, visited, sep), values, -np.inf)))


def pick_plain(candidates, values, visited, sep):
    return int(np.argmax(values))


def pick_flat(candidates, values, visited, sep):
    d = np.sqrt(((candidates[:, None] - visited[None]) ** 2).sum(-1)).min(axis=1)
    return int(np.argmax(np.where(d > sep, values, -np.inf)))


def pick_degrees(candidates, values, visited, sep):  # compares radians with a limit it thinks is in degrees
    d = np.degrees(angular_distance(candidates, visited)).min(axis=1)
    return int(np.argmax(np.where(d > sep, values, -np.inf)))


def pick_argmin(candidates, values, visited, sep):
    ok = far_enough(candidates, visited, sep)
    return int(np.argmin(np.where(ok, values, np.inf)))


def test_pick_best_accepts_correct():
    assert check_pick_best(pick_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [(pick_plain, "plain argmax"), (pick_flat, "flat plane"), (pick_degrees, "do not convert the angles to degrees"),
     (pick_argmin, "HIGHEST")],
)
def test_pick_best_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_pick_best(wrong)
