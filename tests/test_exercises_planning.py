"""The checkers of notebook 05's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest

from stair_lite.config import get_preset
from stair_lite.exercises.planning import (
    check_area_under_curve,
    check_first_step_above,
    check_max_distance_choice,
    fake_records,
)
from stair_lite.geometry import angular_distance, view_to_position
from stair_lite.planners import MIN_SEPARATION, make_planner


# ---- exercise 1: the Max View Distance planner's choice -----------------------------------------
def choice_ok(candidates, visited, min_separation):
    c = view_to_position(candidates[:, 0], candidates[:, 1])
    v = view_to_position(visited[:, 0], visited[:, 1])
    score = ((c[:, None] - v[None]) ** 2).sum(-1).mean(axis=1)
    allowed = angular_distance(candidates, visited).min(axis=1) > min_separation
    return int(np.argmax(np.where(allowed, score, -np.inf)))


def choice_flat(candidates, visited, min_separation):
    score = ((candidates[:, None] - visited[None]) ** 2).sum(-1).mean(axis=1)
    allowed = angular_distance(candidates, visited).min(axis=1) > min_separation
    return int(np.argmax(np.where(allowed, score, -np.inf)))


def choice_min(candidates, visited, min_separation):
    c = view_to_position(candidates[:, 0], candidates[:, 1])
    v = view_to_position(visited[:, 0], visited[:, 1])
    score = ((c[:, None] - v[None]) ** 2).sum(-1).min(axis=1)
    allowed = angular_distance(candidates, visited).min(axis=1) > min_separation
    return int(np.argmax(np.where(allowed, score, -np.inf)))


def choice_no_exclusion(candidates, visited, min_separation):
    c = view_to_position(candidates[:, 0], candidates[:, 1])
    v = view_to_position(visited[:, 0], visited[:, 1])
    return int(np.argmax(((c[:, None] - v[None]) ** 2).sum(-1).mean(axis=1)))


def choice_returns_view(candidates, visited, min_separation):
    return candidates[choice_ok(candidates, visited, min_separation)]


def choice_stub(candidates, visited, min_separation):
    raise NotImplementedError


def test_max_distance_accepts_correct():
    assert check_max_distance_choice(choice_ok)


def test_max_distance_agrees_with_the_library_planner():
    """The checker's notion of 'right' is the one the max_distance baseline planner uses."""
    planner = make_planner("max_distance", get_preset("lite"), seed=3)
    visited = np.array([[np.pi / 2, 0.0], [0.4, 1.0], [0.7, 3.0]])
    decision = planner.next_view(None, visited, (1,))
    assert decision.chosen_index == choice_ok(decision.candidates, visited, MIN_SEPARATION)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (choice_flat, "elevation, azimuth"),
        (choice_min, "CLOSEST"),
        (choice_no_exclusion, "minimum separation"),
        (choice_returns_view, "one integer index"),
        (choice_stub, "NotImplementedError"),
    ],
)
def test_max_distance_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_max_distance_choice(wrong)


# ---- exercise 2: first step above a threshold, area under the curve ---------------------------
def first_ok(records, key, threshold):
    return next((r["step"] for r in records if r[key] > threshold), None)


def first_index(records, key, threshold):  # off by one: 0-based list index
    return next((i for i, r in enumerate(records) if r[key] > threshold), None)


def first_at_least(records, key, threshold):
    return next((r["step"] for r in records if r[key] >= threshold), None)


def first_last(records, key, threshold):
    return next((r["step"] for r in reversed(records) if r[key] > threshold), None)


def first_minus_one(records, key, threshold):
    return next((r["step"] for r in records if r[key] > threshold), -1)


def first_truthy_index(records, key, threshold):  # index + 1, but "if idx" treats step-1 hits as misses
    idx = next((i for i, r in enumerate(records) if r[key] > threshold), None)
    return idx + 1 if idx else None


def test_first_step_accepts_correct():
    assert check_first_step_above(first_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (first_index, "off by one"),
        (first_at_least, "strictly greater"),
        (first_last, "LAST"),
        (first_minus_one, "return None"),
        (first_truthy_index, "step 1 is a valid answer"),
    ],
)
def test_first_step_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_first_step_above(wrong)


def area_ok(records, key):
    return float(np.trapezoid([r[key] for r in records], [r["step"] for r in records]))


def area_sum(records, key):
    return sum(r[key] for r in records)


def area_left(records, key):
    return sum(r[key] for r in records[:-1])


def area_mean(records, key):
    return float(np.mean([r[key] for r in records]))


def test_area_accepts_correct():
    assert check_area_under_curve(area_ok)


@pytest.mark.parametrize("wrong, hint", [(area_sum, "one too many"), (area_left, "left/right"), (area_mean, "mean")])
def test_area_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_area_under_curve(wrong)


def test_fake_records_look_like_a_mission():
    records = fake_records(np.random.default_rng(0), 10)
    assert [r["step"] for r in records] == list(range(1, 11))
    assert all(0 <= r["f1"] <= 1 for r in records)
