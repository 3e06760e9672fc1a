"""Claim verdicts from results tables, and the hidden-object pixel count."""
import numpy as np
import pytest

from dataclasses import replace

from stair_lite.claims import (Comparison, claim_one, compare, claim_three, claim_two, hidden_target_fraction, markdown_report,
                               TOO_FEW_PAIRS, object_pixels, per_seed_scores, tally)
from stair_lite.geometry import TOP_VIEW, Intrinsics
from stair_lite.scenes import build_scene, load_scene_spec, save_scene_spec
from stair_lite.simulator import Simulator


def fake_rows(means: dict, seeds=5, steps=3, noise=0.1, scene="scene1", seed=0):
    """Rows whose per-seed mean over steps is ``mean + noise * N(0, 1)`` for each variant."""
    rng = np.random.default_rng(seed)
    rows = []
    for variant, mean in means.items():
        for k in range(seeds):
            level = mean + noise * rng.normal()
            for step in range(1, steps + 1):
                rows.append({"scene": scene, "variant": variant, "seed": k, "step": step,
                             "psnr": level + (step - 2) * 0.5, "f1": level / 40,
                             "elevation_deg": 90.0 if step == 1 else 10.0, "azimuth_deg": 230.0 * step})
    return rows


def test_per_seed_scores_are_means_over_steps():
    rows = fake_rows({"stair": 20.0}, seeds=2, noise=0.0)
    assert np.allclose(per_seed_scores(rows, "scene1", "stair", "psnr"), [20.0, 20.0])
    assert np.allclose(per_seed_scores(rows, "scene1", "stair", "psnr", step=3), [20.5, 20.5])  # level + (3 - 2) * 0.5
    with pytest.raises(ValueError, match="no results for variant 'ste'"):
        per_seed_scores(rows, "scene1", "ste", "psnr")


def test_verdicts_follow_the_paired_test():
    a, b = np.array([20.0, 20.2, 19.9, 20.1]), np.array([18.0, 18.3, 17.9, 18.1])
    assert Comparison("s", "psnr", "x", "y", a, b).verdict == "holds"
    assert Comparison("s", "psnr", "y", "x", b, a).verdict == "reversed"
    close = Comparison("s", "psnr", "x", "y", a, a + np.array([0.01, -0.02, 0.0, 0.01]))
    assert close.verdict == "not significant" and close.p_value > 0.5
    assert np.isnan(Comparison("s", "psnr", "x", "y", a[:1], b[:1]).p_value)  # one seed: no test
    assert Comparison("s", "psnr", "x", "y", a[:1], b[:1]).verdict == TOO_FEW_PAIRS
    with pytest.raises(ValueError, match="one score per seed on both sides"):
        Comparison("s", "psnr", "x", "y", a, b[:3])


def test_pairing_removes_the_seed_to_seed_spread():
    """Seeds differ a lot (the field initialisation), but within every seed x is 0.1 better than y: the
    paired test sees it; an unpaired (Welch) test would not (p about 0.9)."""
    base = np.array([18.0, 22.0, 20.0, 25.0, 16.0])
    lift = np.array([0.1, 0.12, 0.09, 0.1, 0.11])
    c = Comparison("s", "psnr", "x", "y", base + lift, base)
    assert c.verdict == "holds" and c.p_value < 1e-4
    from scipy import stats
    assert stats.ttest_ind(base + lift, base, equal_var=False).pvalue > 0.5


def test_lower_chamfer_is_better():
    a, b = np.array([0.020, 0.021, 0.019, 0.020]), np.array([0.030, 0.032, 0.029, 0.031])
    assert Comparison("s", "chamfer", "x", "y", a, b).verdict == "holds"
    assert Comparison("s", "chamfer", "y", "x", b, a).verdict == "reversed"


def test_seeds_needed_matches_the_textbook_sample_sizes():
    """Paired t-test, two-sided alpha 0.05, power 0.8: effect size 1 needs 10 pairs, 0.5 needs 34 (Cohen's tables)."""
    from stair_lite.claims import seeds_needed
    assert seeds_needed(1.0, 1.0) == 10
    assert seeds_needed(0.04, 0.02) == 34
    assert seeds_needed(0.04, -0.02) == 34  # the sign does not matter
    # a larger difference never needs more seeds (scipy's far tail underflows to NaN at some effects of 3 seeds)
    needed = [seeds_needed(1.0, d) for d in np.arange(3.0, 12.0, 0.1)]
    assert needed == sorted(needed, reverse=True) and needed[-1] == 2
    with pytest.raises(ValueError, match="positive spread"):
        seeds_needed(0.0, 0.1)


def test_compare_pairs_the_shared_seeds():
    rows = fake_rows({"stair": 20.0, "ste": 18.0}, seeds=4)
    rows = [r for r in rows if not (r["variant"] == "ste" and r["seed"] == 3)]  # ste lacks seed 3
    c = compare(rows, "scene1", "psnr", "stair", "ste")
    assert len(c.claimed_scores) == len(c.other_scores) == 3


def test_claim_one_compares_with_the_strongest_baseline():
    rows = fake_rows({"stair": 20.0, "exploration": 18.0, "fixed": 19.0, "max_distance": 15.0, "uniform": 10.0})
    comparisons = claim_one(rows)
    assert [c.other for c in comparisons] == ["fixed", "fixed"]
    assert tally(comparisons) == {"holds": 2, "not significant": 0, "reversed": 0, TOO_FEW_PAIRS: 0}


def test_claim_two_splits_mapping_and_planning():
    rows = fake_rows({"stair": 20.0, "ste": 18.0, "stair_explicit": 17.0, "ste_implicit": 18.0})
    two = claim_two(rows)
    assert {c.verdict for c in two["overall"]} == {"holds"}
    assert {c.verdict for c in two["planning"]} == {"reversed"}
    assert {c.verdict for c in two["mapping"]} == {"not significant"}


def test_claim_two_at_the_last_step_reads_that_step_only():
    """A map that starts ahead and stops improving wins the mean over the steps and loses the last step: ``step``
    reads each seed's value at that step alone."""
    rows = fake_rows({"stair": 20.0, "ste": 20.0, "stair_explicit": 20.0, "ste_implicit": 20.0, "exploration": 18.0,
                      "fixed": 18.0, "max_distance": 18.0, "uniform": 18.0}, noise=0.0)
    for r in rows:  # stair: +2 at steps 1-2, -1 at step 3 (mean +1); ste as made
        if r["variant"] == "stair":
            r["psnr"] += (2.0 if r["step"] < 3 else -1.0) + 0.01 * r["seed"]
    mean, last = claim_two(rows)["overall"], claim_two(rows, step=3)["overall"]
    assert [c.verdict for c in mean if c.metric == "psnr"] == ["holds"]
    assert [c.verdict for c in last if c.metric == "psnr"] == ["reversed"]
    assert "at the last step (3)" in markdown_report(rows)


def test_claim_three_and_the_report():
    rows = fake_rows({"stair_eps0": 10.0, "stair_eps0.2": 14.0, "stair_eps0.8": 10.05}, scene="ablation_two_chairs")
    three = claim_three(rows)
    assert [c.claimed for c in three] == ["stair_eps0.2", "stair_eps0.2", "stair_eps0.8", "stair_eps0.8"]
    assert [c.verdict for c in three[:2]] == ["holds", "holds"]
    sweep = fake_rows({"stair": 20.0, "exploration": 18.0, "fixed": 19.0, "max_distance": 15.0, "uniform": 10.0,
                       "ste": 18.0, "stair_explicit": 17.0, "ste_implicit": 18.0})
    report = markdown_report(sweep, rows)
    assert "holds in 2 of 2" in report and "Claim (iii)" in report and "missions that saw" in report.lower()


def test_a_report_over_one_seed_says_too_few_pairs_instead_of_a_verdict():
    """One seed gives a difference but no p-value: the report says so rather than "not significant"."""
    one_seed = fake_rows({"stair": 20.0, "exploration": 18.0, "fixed": 19.0, "max_distance": 15.0, "ste": 18.0}, seeds=1)
    report = markdown_report(one_seed)
    assert "(n=1) | - | too few pairs |" in report and "| nan |" not in report
    assert "not significant in 0, too few pairs in 2" in report  # claim (i), psnr and f1 on the one scene
    assert "too few pairs" not in markdown_report(fake_rows({"stair": 20.0, "fixed": 19.0, "ste": 18.0}))


def test_object_pixels_sees_the_hidden_chair_only_from_the_side():
    counts = object_pixels("ablation_two_chairs", 2, np.array([TOP_VIEW, (0.2, 4.0)]))
    assert counts[0] == 0 and counts[1] > 50
    with pytest.raises(ValueError, match="objects 0..5, got index 9"):
        object_pixels("ablation_two_chairs", 9, np.array([TOP_VIEW]))


def test_hidden_target_fraction_counts_the_chair_under_the_table():
    """From the top, the ablation scene's chair under the table is hidden and the other chair is not:
    the hidden fraction is the first chair's share of the two chairs' pixels, each rendered alone."""
    spec = load_scene_spec("ablation_two_chairs")
    k = Intrinsics.from_fov(100, 100)

    def alone(index):
        only = build_scene(replace(spec, objects=(spec.objects[index],)))
        return int((Simulator(only, k).render_view(*TOP_VIEW).labels == spec.objects[index].cls).sum())

    visible, hidden = alone(0), alone(2)
    assert hidden > 50
    assert hidden_target_fraction("ablation_two_chairs", np.array([TOP_VIEW]), k) == pytest.approx(hidden / (visible + hidden))


def test_hidden_target_fraction_is_zero_without_other_objects(tmp_path):
    spec = load_scene_spec("scene3")
    only_targets = replace(spec, name="targets_only", objects=tuple(o for o in spec.objects if o.cls in spec.targets))
    path = save_scene_spec(only_targets, tmp_path / "targets_only.json")
    assert hidden_target_fraction(str(path), np.array([TOP_VIEW, (0.3, 1.0), (0.05, 4.0)])) == 0.0


def test_the_95_percent_interval_leaves_out_zero_exactly_when_the_paired_test_finds_a_difference():
    """Student's interval and the paired t-test are two faces of one computation: over many random pairs, 0 lies
    outside the interval exactly when p < 0.05 (ties at the boundary aside)."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(3, 10))
        base = rng.normal(0, 2, n)
        c = Comparison("s", "psnr", "x", "y", base + rng.normal(rng.normal(0, 0.3), 0.3, n), base)
        low, high = c.interval()
        if abs(c.p_value - 0.05) > 1e-9:
            assert (low > 0 or high < 0) == (c.p_value < 0.05)
        assert low <= c.difference <= high
