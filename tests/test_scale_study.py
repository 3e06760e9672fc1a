"""Lite against the paper scale: the side-by-side verdicts, on made-up studies."""
import numpy as np

from stair_lite.claims import claim_one, claim_two, markdown_report as claims_report
from stair_lite.scale_study import (CHANGES, VARIANTS, changes_with_scale, core_hours, markdown_report, scale_effect,
                                    seeds_by_scene, side_by_side, verdict_change)


def study(means: dict, seeds: int, scenes=("scene1", "scene4"), noise=0.05, seed=0):
    """Rows of every (scene, variant, seed, step) with PSNR about ``means[variant]`` and F1 a fortieth of it, and a
    minute of compute a step."""
    rng = np.random.default_rng(seed)
    rows = []
    for scene in scenes:
        for variant in VARIANTS:
            for k in range(seeds):
                level = means[variant] + noise * rng.normal()
                rows += [{"scene": scene, "variant": variant, "seed": k, "step": step, "psnr": level + step,
                          "f1": level / 40, "time_plan_s": 10.0, "time_train_s": 40.0, "time_evaluate_s": 10.0}
                         for step in (1, 2, 3)]
    return rows


LITE = {"stair": 20.0, "exploration": 18.0, "fixed": 19.0, "max_distance": 15.0, "ste": 17.0}


def test_the_same_missions_at_both_scales_change_no_verdict():
    lite = study(LITE, seeds=8)
    paper = [r for r in lite if r["seed"] < 3]
    entries = side_by_side({"lite": lite, "paper": paper})
    assert len(entries) == 2 * 2 * 3  # claims x metrics x (two scenes and the pool)
    assert not any(changes_with_scale(e) for e in entries)
    assert {len(e["lite"].differences) for e in entries if e["scene"] == "scene1"} == {8}
    assert {len(e["paper"].differences) for e in entries if e["scene"] == "all scenes"} == {6}  # 2 scenes x 3 seeds
    assert all(np.array_equal(e["lite_same"].differences, e["paper"].differences) for e in entries)


def test_an_effect_that_changes_at_the_paper_scale_is_flagged():
    lite = study(LITE, seeds=8)
    # lite's seeds 0-2 with STAIR's and STE's PSNR 1.5 dB lower: the spiral (19) now beats STAIR, STE stays as far behind
    paper = [dict(r, psnr=r["psnr"] - 1.5 * (r["variant"] in ("stair", "ste"))) for r in lite if r["seed"] < 3]
    entries = side_by_side({"lite": lite, "paper": paper})
    one = [e for e in entries if e["claim"] == "(i)" and e["scene"] == "scene1" and e["metric"] == "psnr"][0]
    assert (one["lite"].verdict, one["lite_same"].verdict, one["paper"].verdict) == ("holds", "holds", "reversed")
    assert one["paper"].other == "fixed" and changes_with_scale(one)
    assert np.isclose(scale_effect(one)[0], -1.5, atol=0.2)
    two = [e for e in entries if e["claim"] == "(ii)" and e["scene"] == "scene1" and e["metric"] == "psnr"][0]
    assert two["paper"].verdict == "holds" and not changes_with_scale(two)  # STAIR still 3 ahead of STE
    report = markdown_report({"lite": lite, "paper": paper})
    assert "**yes**" in report and "in 2 of the 8 per-scene comparisons" in report  # claim (i)'s PSNR on both scenes
    assert verdict_change(one) == "flips" and verdict_change(two) is None
    assert "among the 12 comparisons with two pairs at the paper scale: 9 the same; **flips**" in report
    assert "claim (i) scene1 psnr (holds -> reversed), claim (i) scene4 psnr (holds -> reversed), claim (i) all scenes " \
           "psnr (holds -> reversed)." in report


def test_a_verdict_that_differs_at_the_paper_scale_is_sorted_by_what_lite_says_over_the_same_seeds():
    """Lite over the paper study's seeds separates a verdict those seeds still reach at lite from one they do not."""
    from types import SimpleNamespace

    def entry(lite, same, paper):
        return {name: SimpleNamespace(verdict=v) for name, v in (("lite", lite), ("lite_same", same), ("paper", paper))}

    unreached = "not reached over these seeds at lite either"
    assert verdict_change(entry("holds", "holds", "holds")) is None
    assert verdict_change(entry("holds", "not significant", "too few pairs")) is None  # no verdict at the paper scale
    assert verdict_change(entry("too few pairs", "too few pairs", "holds")) is None  # nor at lite
    assert verdict_change(entry("holds", "not significant", "reversed")) == "flips"
    assert verdict_change(entry("reversed", "reversed", "holds")) == "flips"
    assert verdict_change(entry("not significant", "not significant", "holds")) == "new at the paper scale"
    assert verdict_change(entry("holds", "holds", "not significant")) == "lost at the paper scale"
    assert verdict_change(entry("reversed", "not significant", "not significant")) == unreached
    assert verdict_change(entry("holds", "reversed", "not significant")) == unreached
    assert set(CHANGES) == {"flips", "new at the paper scale", "lost at the paper scale", unreached}


def test_the_list_of_changed_verdicts_warns_where_a_test_has_one_degree_of_freedom():
    lite = study(LITE, seeds=8)
    two = markdown_report({"lite": lite, "paper": [r for r in lite if r["seed"] < 2]})
    assert "8 of them have only two pairs at the paper scale" in two  # per scene; the pools have 4 and "t above 12.7" in two
    assert "only two pairs" not in markdown_report({"lite": lite, "paper": [r for r in lite if r["seed"] < 3]})


def test_the_pooled_rows_weigh_every_scene_alike():
    """Scene1 finished three seeds at the paper scale, scene4 one: pooled, each scene gives its seed 0 only."""
    lite = study(LITE, seeds=8)
    paper = [r for r in study(LITE, seeds=3, seed=1) if r["scene"] == "scene1" or r["seed"] == 0]
    entries = side_by_side({"lite": lite, "paper": paper})
    scene1 = [e for e in entries if e["scene"] == "scene1"][0]
    pooled = [e for e in entries if e["scene"] == "all scenes"][0]
    assert len(scene1["paper"].differences) == len(scene1["lite_same"].differences) == 3
    assert len(pooled["paper"].differences) == len(pooled["lite_same"].differences) == 2
    assert len(pooled["lite"].differences) == 16


def test_both_scales_meet_the_baseline_that_was_strongest_at_lite():
    """Three noisy paper-scale seeds do not pick their own opponent: the baseline is lite's strongest (all its seeds)."""
    lite = study(LITE, seeds=8)
    paper = study({**LITE, "exploration": 25.0}, seeds=3, seed=1)  # at the paper scale exploration would be strongest
    entries = side_by_side({"lite": lite, "paper": paper})
    assert {e["paper"].other for e in entries if e["claim"] == "(i)"} == {"fixed"}


def test_an_effect_needs_two_pairs_at_the_paper_scale():
    entries = side_by_side({"lite": study(LITE, seeds=8), "paper": study(LITE, seeds=1)})
    per_scene = [e for e in entries if e["scene"] != "all scenes"]
    assert all(np.isnan(scale_effect(e)[1]) and not changes_with_scale(e) for e in per_scene)
    report = markdown_report({"lite": study(LITE, seeds=8), "paper": study(LITE, seeds=1)})
    assert "in 0 of the 0 per-scene comparisons that have two pairs" in report
    assert "(-) too few pairs" in report and "(-) no" not in report  # no verdict on the scale effect without two pairs
    assert "(n=1, p = -) too few pairs" in report and "(n=1, p = -) n.s." not in report  # nor on one pair


def test_only_whole_seeds_of_the_paper_study_count():
    paper = study(LITE, seeds=3)
    paper = [r for r in paper if not (r["scene"] == "scene4" and r["variant"] == "ste" and r["seed"] == 2)]
    paper = [r for r in paper if not (r["scene"] == "scene1" and r["variant"] == "fixed")]
    assert seeds_by_scene(paper) == {"scene4": [0, 1]}
    assert "No scene has every shared variant" in markdown_report({"lite": study(LITE, 8), "paper": []})


def test_compute_is_summed_over_every_phase():
    rows = study(LITE, seeds=2)
    assert core_hours(rows) == len(rows) * 60.0 / 3600


def test_claims_run_on_a_study_without_uniform_and_the_cross_validation_variants():
    rows = study(LITE, seeds=3)
    assert {c.other for c in claim_one(rows)} == {"fixed"}
    two = claim_two(rows)
    assert two["mapping"] == two["planning"] == [] and len(two["overall"]) == 4
    report = claims_report(rows)
    assert ("**mapping** (the same STE views on the implicit vs the explicit map): no scene has ste_implicit and ste "
            "finished on a shared seed") in report
    only_stair = claims_report([r for r in rows if r["variant"] == "stair"])
    assert "No scene has STAIR and an implicit baseline finished" in only_stair


def test_the_scale_figure_sets_both_scales_side_by_side():
    import matplotlib

    matplotlib.use("Agg")
    from stair_lite.figures.comparison import plot_scale_differences

    lite = study(LITE, seeds=8)
    entries = side_by_side({"lite": lite, "paper": study({**LITE, "stair": 18.5}, seeds=3, seed=1)})
    fig = plot_scale_differences(entries, ("psnr", "f1"))
    assert len(fig.axes) == 4  # two claims x two metrics
    first = fig.axes[0]  # claim (i), psnr: per scene (and pooled) a hollow lite point left of a filled paper point
    assert [t.get_text() for t in first.get_xticklabels()] == ["scene1", "scene4", "all scenes"]
    assert len(first.lines) >= 6


def test_scale_claims_of_a_folder_without_the_studies_is_one_line(tmp_path):
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "stair_lite", "scale-claims", "--results", str(tmp_path)],
                          capture_output=True, text=True)
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "holds neither comparison_lite nor comparison_paper" in done.stderr


def test_the_verdict_map_sets_each_scene_and_metric_at_both_scales_and_marks_a_change():
    from stair_lite.scale_study import verdict_map
    lite = study(LITE, seeds=8)
    paper = [dict(r, psnr=r["psnr"] - 1.5 * (r["variant"] in ("stair", "ste"))) for r in lite if r["seed"] < 3]
    entries = side_by_side({"lite": lite, "paper": paper})
    table = verdict_map(entries, "(i)")
    assert table[0] == "| scene | psnr | f1 |" and len(table) == 2 + 3  # header, rule, two scenes and the pool
    assert table[2] == "| scene1 | **holds -> reversed** | holds -> holds |"  # the spiral now beats STAIR's PSNR
    assert table[-1].startswith("| all scenes | **holds -> reversed** |")
    assert "**" not in "".join(verdict_map(entries, "(ii)"))  # STAIR stays as far ahead of STE: nothing changes
    assert "Claim (i) at a glance" in markdown_report({"lite": lite, "paper": paper})
