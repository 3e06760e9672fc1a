"""The label-noise study's verdicts: pairs by (scene, seed), the exact level's missions borrowed from the comparison."""
import numpy as np

from stair_lite.noise_study import LEVELS, markdown_report, pooled, study_rows


def rows_of(variant, scene, seeds, f1, psnr=20.0):
    return [{"scene": scene, "variant": variant, "seed": s, "step": step, "f1": f1 + 0.01 * s, "psnr": psnr + s}
            for s in seeds for step in (1, 2)]


def test_pooled_pairs_each_scene_and_seed_that_both_variants_ran():
    rows = (rows_of("stair", "scene1", [0, 1, 2], 0.5) + rows_of("stair_semantic", "scene1", [0, 1], 0.6)
            + rows_of("stair", "scene2", [0, 1], 0.3) + rows_of("stair_semantic", "scene2", [1], 0.2))
    c = pooled(rows, "f1", "stair_semantic", "stair")
    assert len(c.claimed_scores) == 3  # scene1 seeds 0 and 1, scene2 seed 1
    np.testing.assert_allclose(c.differences, [0.1, 0.1, -0.1])
    assert pooled(rows, "f1", "stair_soft", "stair") is None


def test_a_consistent_gain_is_called_helps_and_missing_pairs_are_said():
    rows = rows_of("stair", "scene1", range(6), 0.5) + [
        {**r, "variant": "stair_semantic", "f1": r["f1"] + 0.05 + 0.001 * r["seed"]} for r in rows_of("stair", "scene1", range(6), 0.5)]
    report = markdown_report({"none": rows, "low": [], "high": rows_of("stair", "scene1", [0], 0.4)})
    assert "stair_semantic on f1: **helps**" in report and "stair_semantic on psnr: **no significant difference**" in report
    assert report.count("No pair of a utility variant and STAIR has finished yet.") == 2


def test_study_rows_take_the_exact_levels_paper_variants_from_the_comparison(tmp_path):
    by_level = study_rows(tmp_path / "nothing", log=lambda m: None)
    assert set(by_level) == set(LEVELS) and not any(by_level.values())
    from stair_lite.experiments import RESULTS_DIR

    stored = study_rows(RESULTS_DIR, log=lambda m: None)
    variants = {r["variant"] for r in stored["none"]}
    assert {"stair", "exploration", "max_distance"} <= variants and not variants & {"fixed", "ste", "uniform"}


def test_a_single_pair_gets_no_verdict():
    """One (scene, seed) pair has no spread: no p-value, and the report says so instead of a verdict."""
    rows = rows_of("stair", "scene1", [0], 0.5) + rows_of("stair_soft", "scene1", [0], 0.7)
    report = markdown_report({"none": rows})
    assert "stair_soft on f1: **too few pairs**" in report
    assert "| scene1 | f1 | stair_soft 0.700 | stair 0.500 | +0.200 ± 0.000 (n=1) | - | too few pairs |" in report
    assert "nan" not in report


def test_stair_against_a_baseline_is_worded_from_stairs_side():
    """A baseline that scores lower than STAIR on every pair makes STAIR better; no baseline pair, no table."""
    stair = rows_of("stair", "scene1", range(5), 0.5)
    weaker = [{**r, "variant": "exploration", "f1": r["f1"] - 0.1 - 0.001 * r["seed"]} for r in stair]
    report = markdown_report({"high": stair + weaker})
    assert "exploration on f1: **STAIR better**" in report
    assert "| all scenes | f1 | stair 0.520 | exploration 0.418 | +0.102 ± 0.001 (n=5) |" in report
    assert "max_distance on" not in report
    assert "semantics-blind" not in markdown_report({"high": stair})
