"""The checkers of notebook 05's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest

from stair_lite.config import get_preset
from stair_lite.exercises.planning import check_area_under_curve, check_choose_view, check_first_step_above, fake_records
from stair_lite.geometry import TOP_VIEW, view_to_pose
from stair_lite.maps import ImplicitMap
from stair_lite.planners import far_enough, make_planner
from stair_lite.scenes import load_scene
from stair_lite.simulator import Simulator


# ---- exercise 1: the exploration weight decides -------------------------------------------------
def choose_ok(exploitation, exploration, epsilon, allowed):
    return int(np.argmax(np.where(allowed, exploitation + epsilon * exploration, -np.inf)))


def choose_no_exclusion(exploitation, exploration, epsilon, allowed):
    return int(np.argmax(exploitation + epsilon * exploration))


def choose_eps_on_exploitation(exploitation, exploration, epsilon, allowed):
    return choose_ok(exploration, exploitation, epsilon, allowed)


def choose_convex(exploitation, exploration, epsilon, allowed):
    return choose_ok((1 - epsilon) * exploitation, exploration, epsilon, allowed)


def choose_exploitation_only(exploitation, exploration, epsilon, allowed):
    return choose_ok(exploitation, exploration, 0.0, allowed)


def choose_lowest(exploitation, exploration, epsilon, allowed):
    return int(np.argmin(np.where(allowed, exploitation + epsilon * exploration, np.inf)))


def choose_returns_scores(exploitation, exploration, epsilon, allowed):
    return exploitation + epsilon * exploration


def choose_stub(exploitation, exploration, epsilon, allowed):
    raise NotImplementedError


def test_choose_view_accepts_correct():
    assert check_choose_view(choose_ok)


def test_choose_view_agrees_with_the_library_planner():
    """The checker's notion of 'right' is the choice the STAIR planner makes from its scored candidates."""
    preset = get_preset("lite")
    scene = load_scene("scene1")
    implicit = ImplicitMap.from_preset(preset, seed=0)
    implicit.add_measurement(Simulator(scene).render(view_to_pose(*TOP_VIEW)))
    implicit.trainer.update(5)
    visited = np.array([TOP_VIEW])
    decision = make_planner("stair", preset, seed=1).next_view(implicit.field, visited, scene.targets)
    s = decision.scores
    assert decision.chosen_index == choose_ok(s.exploitation, s.exploration, preset.plan.epsilon,
                                              far_enough(decision.candidates, visited))


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (choose_no_exclusion, "not allowed"),
        (choose_eps_on_exploitation, "EXPLORATION term"),
        (choose_convex, "does not blend"),
        (choose_exploitation_only, "ignored epsilon"),
        (choose_lowest, "HIGHEST"),
        (choose_returns_scores, "one integer index"),
        (choose_stub, "NotImplementedError"),
    ],
)
def test_choose_view_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_choose_view(wrong)


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


# ---- the mission loop ----------------------------------------------------------------------------
from stair_lite.exercises.planning import _mission_reference, check_mission_loop  # noqa: E402


def loop(world, reconstruction, planner, budget, top_first=True, extra=0, zero_based=False, evaluate_first=False,
         forget_visited=False, give_map=False):
    visited, records = [], []
    for step in range(1, budget + 1 + extra):
        if step == 1 and top_first:
            view = np.array(TOP_VIEW)
        else:
            source = reconstruction if give_map else reconstruction.planning_source
            seen = np.array(visited[:1] if forget_visited else visited).reshape(-1, 2)
            view = planner.next_view(source, seen, world.targets).view
        measurement = world.measure(view, step - 1 if zero_based else step)
        if evaluate_first:
            result = world.evaluator.evaluate(reconstruction)
            reconstruction.integrate(measurement)
        else:
            reconstruction.integrate(measurement)
            result = world.evaluator.evaluate(reconstruction)
        visited.append(np.asarray(view, float))
        records.append({"step": step, "view_rad": list(view), "psnr": result["psnr"], "f1": result["f1"]})
    return records


def test_mission_loop_accepts_a_correct_loop():
    assert check_mission_loop(_mission_reference)
    assert check_mission_loop(loop)


@pytest.mark.parametrize("wrong, hint", [
    (dict(top_first=False), "top view"),
    (dict(extra=1), "budget counts measurements"),
    (dict(zero_based=True), "numbered from 1"),
    (dict(evaluate_first=True), "after it has integrated"),
    (dict(forget_visited=True), "every view measured so far"),
    (dict(give_map=True), "planning_source"),
])
def test_mission_loop_rejects_plausible_mistakes(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_mission_loop(lambda *args: loop(*args, **wrong))


def test_mission_loop_rejects_records_that_do_not_match_the_steps():
    def shifted(world, reconstruction, planner, budget):
        records = loop(world, reconstruction, planner, budget)
        return [{**r, "f1": records[max(0, i - 1)]["f1"]} for i, r in enumerate(records)]

    with pytest.raises(AssertionError, match="record 2"):
        check_mission_loop(shifted)
