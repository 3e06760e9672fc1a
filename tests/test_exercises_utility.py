"""The checkers of notebook 04's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest
import torch

from stair_lite.config import get_preset
from stair_lite.exercises.utility import check_ray_entropy, check_two_stage_search, check_utility
from stair_lite.field import SemanticField
from stair_lite.geometry import TOP_VIEW, angular_distance, fibonacci_hemisphere, local_views
from stair_lite.planners import far_enough, make_planner
from stair_lite.rendering import compositing_weights
from stair_lite.utility import FieldSnapshot, point_entropy, score_views


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


# ---- exercise 3: the two-stage search -------------------------------------------------------------
def _search(score, visited, azimuth_offset, resample, n_uniform, top_k, centres_of, best_of="all", skip_visited=True):
    uniform = fibonacci_hemisphere(n_uniform, azimuth_offset=azimuth_offset)
    first = score(uniform)
    resampled = np.concatenate([resample(uniform[i]) for i in centres_of(first, far_enough(uniform, visited), top_k)])
    candidates = np.concatenate([uniform, resampled])
    values = score(candidates)
    ok = far_enough(candidates, visited) if skip_visited else np.ones(len(candidates), bool)
    if best_of == "second":
        ok[:n_uniform] = False
    return candidates, values, int(np.argmax(np.where(ok, values, -np.inf)))


def top_allowed(first, allowed, k):
    return [i for i in np.argsort(-first) if allowed[i]][:k]


def search_ok(*args):
    return _search(*args, centres_of=top_allowed)


def search_reversed_draws(score, visited, azimuth_offset, resample, n_uniform, top_k):  # same search, other order
    candidates, values, best = search_ok(score, visited, azimuth_offset, resample, n_uniform, top_k)
    order = np.arange(len(values))[::-1]
    return candidates[order], values[order], int(np.flatnonzero(order == best)[0])


def search_top_of_all(*args):
    return _search(*args, centres_of=lambda first, allowed, k: list(np.argsort(-first)[:k]))


def search_lowest(*args):
    return _search(*args, centres_of=lambda first, allowed, k: [i for i in np.argsort(first) if allowed[i]][:k])


def search_second_only(*args):
    return _search(*args, centres_of=top_allowed, best_of="second")


def search_visited_allowed(*args):
    return _search(*args, centres_of=top_allowed, skip_visited=False)


def search_drawn_worst_first(*args):  # the right views, resampled in ascending order
    return _search(*args, centres_of=lambda first, allowed, k: top_allowed(first, allowed, k)[::-1])


def search_first_stage_only(score, visited, azimuth_offset, resample, n_uniform, top_k):
    uniform = fibonacci_hemisphere(n_uniform, azimuth_offset=azimuth_offset)
    values = score(uniform)
    return uniform, values, int(np.argmax(np.where(far_enough(uniform, visited), values, -np.inf)))


def search_unturned(score, visited, azimuth_offset, resample, n_uniform, top_k):  # forgets the azimuth offset
    return search_ok(score, visited, 0.0, resample, n_uniform, top_k)


def search_subset_positions(*args):  # ranks the allowed views, then reads those ranks as indices into all of them
    return _search(*args, centres_of=lambda first, allowed, k: list(np.argsort(-first[allowed])[:k]))


def test_two_stage_search_accepts_correct():
    assert check_two_stage_search(search_ok)
    assert check_two_stage_search(search_reversed_draws)
    assert check_two_stage_search(search_drawn_worst_first)  # the draws' order is free: resample is a function of the view


@pytest.mark.parametrize(
    "wrong, hint",
    [(search_top_of_all, "ALLOWED"), (search_lowest, "HIGHEST"), (search_second_only, "first stage's included"),
     (search_visited_allowed, "far_enough from every visited view"), (search_first_stage_only, "shape"),
     (search_unturned, "azimuth_offset"), (search_subset_positions, "not the expected set")],
)
def test_two_stage_search_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_two_stage_search(wrong)


def test_two_stage_search_reference_is_the_planners_search():
    """The checker's reference, fed the planner's random draws, makes STAIR's choice (planners.UtilityPlanner)."""
    preset = get_preset("smoke")
    field = SemanticField(preset.field, seed=0)
    planner = make_planner("stair", preset, seed=5)
    visited = np.array([TOP_VIEW])
    decision = planner.next_view(field, visited, (1,))
    rng = np.random.default_rng(5)
    snapshot, cfg = FieldSnapshot(field), preset.plan
    score = lambda views: score_views(snapshot, views, (1,), planner.intrinsics, cfg.candidate_samples,  # noqa: E731
                                      planner.options).utility
    resample = lambda view: local_views(view, cfg.n_resample, rng, *cfg.resample_angle)  # noqa: E731
    candidates, _, best = check_two_stage_search.reference(score, visited, rng.uniform(0, 2 * np.pi), resample,
                                                            cfg.n_uniform, cfg.top_k)
    assert np.array_equal(candidates, decision.candidates) and best == decision.chosen_index
    # the views the planner resampled around, in the order it drew: each block of its second stage lies around one
    centres = decision.info["resampled_around"]
    assert len(centres) == cfg.top_k
    blocks = decision.candidates[cfg.n_uniform:].reshape(cfg.top_k, cfg.n_resample, 2)
    for centre, block in zip(centres, blocks):
        distance = angular_distance(block, centre[None])[:, 0]
        assert np.all((distance >= cfg.resample_angle[0] - 1e-9) & (distance <= cfg.resample_angle[1] + 1e-9))
