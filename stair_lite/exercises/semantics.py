"""Checkers for the exercises of notebook 03 (semantic rendering, target-only maps, replay).

Each ``check_*`` takes the learner's function, calls it on several seeded random inputs, compares
the answers with an independent computation written here in plain numpy, and raises
``AssertionError`` with a hint when they differ. Where a wrong answer matches a common mistake
(forgetting the background remainder, thresholding a probability instead of taking the argmax,
sampling proportional to the use count, ...) the hint names that mistake. On success a checker
prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np

from ..classes import BACKGROUND, NUM_CLASSES
from .common import as_array as _as_array, call as _call, compares_with

_ATOL = 1e-6


def _close(a, b, atol: float = _ATOL) -> bool:
    return bool(np.allclose(a, b, atol=atol, rtol=1e-7))


def _softmax(logits: np.ndarray) -> np.ndarray:
    z = logits - logits.max(axis=-1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=-1, keepdims=True)


def _random_ray(rng: np.random.Generator, n_samples: int):
    """Weights w_i = o_i prod_{j<i} (1 - o_j) of a random ray (sum <= 1) and per-sample class probabilities."""
    occ = rng.uniform(0.0, 1.0, n_samples) * (rng.uniform(size=n_samples) < 0.5)  # about half the samples empty
    if rng.uniform() < 0.3:
        occ *= 0.2  # a faint ray: much of it goes to the background remainder
    transmittance = np.cumprod(np.r_[1.0, 1.0 - occ[:-1]])
    weights = occ * transmittance
    probs = _softmax(rng.normal(0.0, 2.0, size=(n_samples, NUM_CLASSES)))
    return weights, probs


# --------------------------------------------------------------------------------------------------
# Exercise 1: the rendered semantic vector of one ray (Eq. 4 plus the background remainder)
# --------------------------------------------------------------------------------------------------
def _semantics_reference(weights, probs):
    s = weights @ probs
    s[BACKGROUND] += 1.0 - weights.sum()
    return s


@compares_with(_semantics_reference)
def check_render_semantics(render_semantics, n_trials: int = 100, seed: int = 0) -> bool:
    """``render_semantics(weights, probs)`` takes the compositing weights (S,) of one ray and the class
    probabilities (S, P) of its samples, and returns the rendered class distribution (P,):
    S = sum_i w_i s_i, with what the ray does not hit (1 - sum_i w_i) added to the background class 0."""
    rng = np.random.default_rng(seed)
    for trial in range(n_trials):
        n = int(rng.integers(2, 40))
        weights, probs = _random_ray(rng, n)
        got = _as_array(_call(render_semantics, weights.copy(), probs.copy()), (NUM_CLASSES,), "render_semantics(weights, probs)")
        want = _semantics_reference(weights, probs)
        if _close(got, want):
            continue
        plain = weights @ probs
        if _close(got, plain):
            hint = ("you rendered sum_i w_i s_i only: the ray's remaining weight 1 - sum_i w_i (nothing hit) must go to "
                    "the background class 0, so that the result is a distribution (sums to 1)")
        elif weights.sum() > 0 and _close(got, plain / weights.sum()):
            hint = ("you normalised by sum_i w_i: that hides how little the ray hit; instead add the remainder "
                    "1 - sum_i w_i to the background class 0")
        elif any(_close(got, plain + (1.0 - weights.sum()) * np.eye(NUM_CLASSES)[k]) for k in range(1, NUM_CLASSES)):
            hint = "the remainder 1 - sum_i w_i went to the wrong class: it belongs to the background, class 0"
        elif _close(got[1:], want[1:]) and not _close(got[0], want[0]):
            hint = "the object classes are right but the background entry is not: it is sum_i w_i s_i[0] + (1 - sum_i w_i)"
        elif _close(got, probs.mean(axis=0)):
            hint = "you averaged the samples' probabilities: weight each sample by its compositing weight w_i"
        elif not _close(got.sum(), 1.0):
            hint = f"your vector sums to {got.sum():.4f}, but a rendered class distribution must sum to 1"
        else:
            hint = ("compare with Eq. 4 and section 2 on a ray of one sample: what the sample contributes, and where the "
                    "probability the ray does not stop goes")
        raise AssertionError(
            f"render_semantics is wrong for a ray with {n} samples (sum of weights {weights.sum():.4f}): "
            f"got {np.round(got, 4)}, expected {np.round(want, 4)}\nHint: {hint}"
        )
    print(f"check_render_semantics: {n_trials} random rays agree, each a distribution over the {NUM_CLASSES} classes")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 2: target-only occupancy
# --------------------------------------------------------------------------------------------------
def _target_only_reference(occ, logits, targets):
    return occ * np.isin(logits.argmax(axis=1), targets)


@compares_with(_target_only_reference)
def check_target_only_occupancy(target_only_occupancy, n_trials: int = 50, seed: int = 0) -> bool:
    """``target_only_occupancy(occ, logits, targets)`` takes occupancies (N,), semantic logits (N, P) and a
    tuple of target class ids, and returns new occupancies (N,): unchanged where the argmax class is a
    target, 0 everywhere else (background and non-target objects alike). The inputs must not be modified."""
    rng = np.random.default_rng(seed)
    for trial in range(n_trials):
        n = int(rng.integers(50, 300))
        occ = rng.uniform(0.0, 1.0, n)
        logits = rng.normal(0.0, 1.0, size=(n, NUM_CLASSES))
        targets = tuple(sorted(rng.choice(np.arange(1, NUM_CLASSES), size=int(rng.integers(1, 3)), replace=False).tolist()))
        occ_in, logits_in = occ.copy(), logits.copy()
        got = _as_array(_call(target_only_occupancy, occ_in, logits_in, targets), (n,), "target_only_occupancy(occ, logits, targets)")
        if not (np.array_equal(occ_in, occ) and np.array_equal(logits_in, logits)):
            raise AssertionError("target_only_occupancy modified its inputs: return a new array (e.g. occ * mask)\n"
                                 "Hint: in the renderer the same occupancies also feed other outputs")
        want = _target_only_reference(occ, logits, targets)
        if _close(got, want):
            continue
        label = logits.argmax(axis=1)
        probs = _softmax(logits)
        if _close(got, occ * (label != BACKGROUND)):
            hint = "you removed only the background: samples of non-target object classes must be removed too"
        elif _close(got, occ * ~np.isin(label, targets)):
            hint = "the mask is inverted: keep the samples whose class IS a target, zero the others"
        elif _close(got, occ * (probs[:, list(targets)].sum(axis=1) > 0.5)) or _close(got, occ * (probs[:, list(targets)].max(axis=1) > 0.5)):
            hint = ("you thresholded the target probability at 0.5: the rule is the argmax class (with 7 classes a "
                    "target can win with less than half the probability)")
        elif len(targets) > 1 and _close(got, occ * (label == targets[0])):
            hint = ("you kept only the first target class: a sample stays if its class is ANY of the targets "
                    "(np.isin(label, targets))")
        elif _close(got, occ * np.isin(logits[:, 1:].argmax(axis=1) + 1, targets)):
            hint = "take the argmax over all classes, background included"
        elif _close(got, occ * np.isin(label, targets) * probs[np.arange(n), label]):
            hint = "do not scale the occupancy by the class probability: keep it unchanged or set it to 0"
        else:
            hint = ("a sample keeps its occupancy only if its most likely class is a target (Sec. IV-A); check one sample whose "
                    "class is a target and one whose class is not")
        i = int(np.argmax(np.abs(got - want)))
        raise AssertionError(
            f"target_only_occupancy is wrong for targets {targets}: sample {i} with logits {np.round(logits[i], 3)} "
            f"and occupancy {occ[i]:.4f} gave {got[i]:.4f}, expected {want[i]:.4f}\nHint: {hint}"
        )
    print(f"check_target_only_occupancy: {n_trials} random batches agree, inputs untouched")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 3: replay probabilities from use counts
# --------------------------------------------------------------------------------------------------
def _replay_reference(counts):
    w = 1.0 / (1.0 + counts)
    return w / w.sum()


@compares_with(_replay_reference)
def check_replay_probabilities(replay_probabilities, n_trials: int = 50, seed: int = 0) -> bool:
    """``replay_probabilities(use_counts)`` takes the integer use counts (N,) of the old rays (0 = never used
    in a batch yet) and returns the probability (N,) of drawing each one as the next replay ray:
    proportional to 1 / (1 + count), summing to 1 (``stair_lite.training.RayBuffer.replay_indices``)."""
    rng = np.random.default_rng(seed)
    cases = [np.zeros(5, dtype=np.int64), np.array([0, 1, 2, 3, 100])]
    for _ in range(n_trials):
        cases.append(rng.integers(0, 8, size=int(rng.integers(2, 200))))
    for counts in cases:
        counts_in = counts.copy()
        with np.errstate(divide="ignore", invalid="ignore"):
            out = _call(replay_probabilities, counts_in)
        got = _as_array(out, counts.shape, "replay_probabilities(use_counts)")
        if not np.array_equal(counts_in, counts):
            raise AssertionError("replay_probabilities modified the use counts: return a new array")
        want = _replay_reference(counts)
        if np.all(np.isfinite(got)) and _close(got, want, 1e-9):
            continue
        c = counts.astype(np.float64)
        if not np.all(np.isfinite(got)):
            hint = ("your answer has inf or nan: a count of 0 (a ray never used) makes 1 / count blow up; "
                    "the weight is 1 / (1 + count)")
        elif _close(got, 1.0 / (1.0 + c)):
            hint = "the weights 1 / (1 + count) are right, but normalise them so that they sum to 1"
        elif c.sum() > 0 and _close(got, c / c.sum()):
            hint = "that is proportional to the count: rarely used rays must be MORE likely, so use 1 / (1 + count)"
        elif _close(got, np.full(len(c), 1.0 / len(c))) and not _close(want, got):
            hint = "that is uniform sampling: the probability must fall with the use count, 1 / (1 + count)"
        elif _close(got, (w := 1.0 / (1.0 + c) ** 2) / w.sum()):
            hint = "you squared the count's weight: the paper's rule is inversely proportional, 1 / (1 + count)"
        elif _close(got, (w := np.exp(-c)) / w.sum()):
            hint = "exp(-count) is a softmax of the counts, not inverse proportionality: use 1 / (1 + count)"
        else:
            hint = ("re-read the replay rule of the section: how a ray's chance depends on how often it was drawn, and what the "
                    "chances of all rays must add up to")
        raise AssertionError(
            f"replay_probabilities is wrong for counts {counts[:8]}{' ...' if len(counts) > 8 else ''}: "
            f"got {np.round(got[:8], 4)}, expected {np.round(want[:8], 4)}\nHint: {hint}"
        )
    print(f"check_replay_probabilities: {len(cases)} sets of use counts agree")
    return True
