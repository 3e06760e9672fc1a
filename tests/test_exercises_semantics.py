"""The checkers of notebook 03's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest

from stair_lite.exercises.semantics import check_render_semantics, check_replay_probabilities, check_target_only_occupancy


# ---- exercise 1: rendered semantics of one ray ---------------------------------------------------
def semantics_ok(weights, probs):
    s = weights @ probs
    s[0] += 1.0 - weights.sum()
    return s


def semantics_no_background(weights, probs):
    return weights @ probs


def semantics_normalised(weights, probs):
    return weights @ probs / max(weights.sum(), 1e-12)


def semantics_mean(weights, probs):
    return probs.mean(axis=0)


def semantics_last_class(weights, probs):
    s = weights @ probs
    s[-1] += 1.0 - weights.sum()
    return s


def semantics_stub(weights, probs):
    raise NotImplementedError


def test_render_semantics_accepts_correct():
    assert check_render_semantics(semantics_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (semantics_no_background, "remaining weight"),
        (semantics_normalised, "normalised"),
        (semantics_mean, "averaged"),
        (semantics_last_class, "wrong class"),
        (semantics_stub, "NotImplementedError"),
    ],
)
def test_render_semantics_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_render_semantics(wrong)


# ---- exercise 2: target-only occupancy -----------------------------------------------------------
def target_ok(occ, logits, targets):
    return occ * np.isin(logits.argmax(axis=1), targets)


def target_background_only(occ, logits, targets):
    return occ * (logits.argmax(axis=1) != 0)


def target_inverted(occ, logits, targets):
    return occ * ~np.isin(logits.argmax(axis=1), targets)


def target_threshold(occ, logits, targets):
    p = np.exp(logits - logits.max(axis=1, keepdims=True))
    p /= p.sum(axis=1, keepdims=True)
    return occ * (p[:, list(targets)].sum(axis=1) > 0.5)


def target_in_place(occ, logits, targets):
    occ[~np.isin(logits.argmax(axis=1), targets)] = 0.0
    return occ


def target_first_only(occ, logits, targets):  # as if there were one target class
    return occ * (logits.argmax(axis=1) == targets[0])


def target_none(occ, logits, targets):
    return None


def test_target_only_occupancy_accepts_correct():
    assert check_target_only_occupancy(target_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (target_background_only, "only the background"),
        (target_inverted, "inverted"),
        (target_threshold, "thresholded"),
        (target_in_place, "modified its inputs"),
        (target_none, "None"),
        (target_first_only, "ANY of the targets"),
    ],
)
def test_target_only_occupancy_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_target_only_occupancy(wrong)


# ---- exercise 3: replay probabilities ------------------------------------------------------------
def replay_ok(counts):
    w = 1.0 / (1.0 + counts)
    return w / w.sum()


def replay_inverse_count(counts):
    w = 1.0 / counts
    return w / w.sum()


def replay_unnormalised(counts):
    return 1.0 / (1.0 + counts)


def replay_proportional(counts):
    c = counts.astype(float) + 1.0
    return c / c.sum()


def replay_uniform(counts):
    return np.full(len(counts), 1.0 / len(counts))


def replay_squared(counts):
    w = 1.0 / (1.0 + counts) ** 2
    return w / w.sum()


def test_replay_probabilities_accepts_correct():
    assert check_replay_probabilities(replay_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (replay_inverse_count, "inf or nan"),
        (replay_unnormalised, "normalise"),
        (replay_proportional, "replay_probabilities is wrong"),
        (replay_uniform, "uniform"),
        (replay_squared, "squared"),
    ],
)
def test_replay_probabilities_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_replay_probabilities(wrong)


def test_replay_probabilities_match_raybuffer_first_draw():
    """The checker's rule is RayBuffer's: with n = 1 the exponential-keys draw picks ray i with probability w_i / sum w."""
    from stair_lite.geometry import Intrinsics, view_to_pose
    from stair_lite.measurement import Measurement
    from stair_lite.training import RayBuffer

    def tiny(width):  # a one-row measurement of ``width`` background pixels
        k = Intrinsics.from_fov(width, 1)
        return Measurement(np.ones((1, width, 3), np.float32), np.zeros((1, width), np.float32),
                           np.zeros((1, width), np.int64), view_to_pose(np.pi / 2, 0.0), k)

    buffer = RayBuffer()
    buffer.add(tiny(5))
    buffer.add(tiny(1))  # two views: the first five rays are old
    counts = np.array([0, 0, 1, 3, 9])
    buffer.use_counts = np.r_[counts, 0]
    rng = np.random.default_rng(0)
    draws = np.array([buffer.replay_indices(1, rng)[0] for _ in range(20000)])
    freq = np.bincount(draws, minlength=5)[:5] / len(draws)
    assert np.allclose(freq, replay_ok(counts), atol=0.015)
