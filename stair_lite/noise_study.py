"""When the labels lie: the label-noise study's verdicts (beyond the paper; notebook 07, RESULTS.md).

The study (``scripts/label_noise_sweep.sh``) runs STAIR, STAIR with the semantic-uncertainty term
(``stair_semantic``), STAIR with the soft target mask (``stair_soft``), Exploration and Max View Distance on
the four paper scenes at label noise none, low and high (``segmenter.LABEL_NOISE``), one folder per level.
At level none the paper's variants are the missions of the comparison of the same map (the same missions: exact
labels). A study is named by its folders' suffix: ``label_noise_<level>_<study>`` and ``comparison_<study>``.
``STORED_STUDY`` is ``lite``: the study on the adopted lite map (the unknown marked in planning renders); the study on
the map before the headroom league (unknown space unmarked, the voxel map at 128^3) is ``lite_former``.

Each utility variant is compared with STAIR as ``claims`` compares planners: per-seed means over the steps,
a paired t-test at ``claims.ALPHA``; per scene, and pooled over the scenes (pairs of the same scene and seed).
A verdict reads "helps" (the variant is better), "hurts" or "no significant difference". Beside them, per
level, STAIR against the two semantics-blind baselines (pooled over the scenes): does targeting still pay when
the labels that define the targets lie? A verdict there reads "STAIR better", "STAIR worse" or "no significant
difference".
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .claims import TOO_FEW_PAIRS, Comparison, compare, per_seed_scores, scenes_of, seeds_of
from .experiments import RESULTS_DIR, collect
from .metrics import METRICS as REGISTERED_METRICS

LEVELS = ("none", "low", "high")
VARIANTS = ("stair", "stair_semantic", "stair_soft", "exploration", "max_distance")
AGAINST_STAIR = ("stair_semantic", "stair_soft")  # the utilities beyond the paper, each against the paper's
BASELINES = ("exploration", "max_distance")  # semantics-blind: STAIR is compared against each
METRICS = ("psnr", "f1")
STORED_STUDY = "lite"  # the study whose verdicts RESULTS.md and notebook 07 quote
WORDS = {"holds": "helps", "reversed": "hurts", "not significant": "no significant difference",
         TOO_FEW_PAIRS: TOO_FEW_PAIRS}
STAIR_WORDS = {"holds": "STAIR better", "reversed": "STAIR worse", "not significant": "no significant difference",
               TOO_FEW_PAIRS: TOO_FEW_PAIRS}


def folder(level: str, root: Path = RESULTS_DIR, study: str = STORED_STUDY) -> Path:
    return Path(root) / f"label_noise_{level}_{study}"


def study_rows(root: Path = RESULTS_DIR, log=print, study: str = STORED_STUDY) -> dict[str, list[dict]]:
    """Level -> the finished missions of the study's variants at that level (an absent folder: none yet); level none
    adds the comparison's missions (``comparison_<study>``: stair, exploration and max_distance with exact labels)."""
    out = {}
    exact = Path(root) / f"comparison_{study}"
    for level in LEVELS:
        rows = collect(folder(level, root, study), log) if folder(level, root, study).exists() else []
        if level == "none" and exact.exists():
            rows += [r for r in collect(exact, log) if r["variant"] in VARIANTS]
        out[level] = [r for r in rows if r["variant"] in VARIANTS]
    return out


def pooled(rows: list[dict], metric: str, claimed: str, other: str) -> Comparison | None:
    """The comparison over every (scene, seed) both variants ran, each scene's seeds in order (None: no pair)."""
    claimed_scores, other_scores = [], []
    for scene in scenes_of(rows):
        seeds = sorted(set(seeds_of(rows, scene, claimed)) & set(seeds_of(rows, scene, other)))
        if seeds:
            claimed_scores += list(per_seed_scores(rows, scene, claimed, metric, seeds=seeds))
            other_scores += list(per_seed_scores(rows, scene, other, metric, seeds=seeds))
    if not claimed_scores:
        return None
    return Comparison("all scenes", metric, claimed, other, np.array(claimed_scores), np.array(other_scores))


def per_scene(rows: list[dict], metric: str, claimed: str, other: str) -> list[Comparison]:
    return [compare(rows, scene, metric, claimed, other) for scene in scenes_of(rows)
            if set(seeds_of(rows, scene, claimed)) & set(seeds_of(rows, scene, other))]


def _line(c: Comparison, words: dict[str, str] = WORDS) -> str:
    a, b, d = c.claimed_scores, c.other_scores, REGISTERED_METRICS[c.metric].digits
    p = f"{c.p_value:.3f}" if len(a) >= 2 else "-"
    return (f"| {c.scene} | {c.metric} | {c.claimed} {a.mean():.{d}f} | {c.other} {b.mean():.{d}f} | "
            f"{c.difference:+.{d}f} ± {c.differences.std():.{d}f} (n={len(a)}) | {p} | {words[c.verdict]} |")


def _baselines(rows: list[dict]) -> list[str]:
    """STAIR against each semantics-blind baseline at one level, pooled over the scenes (empty: no pair yet)."""
    pairs = [c for baseline in BASELINES for metric in METRICS if (c := pooled(rows, metric, "stair", baseline))]
    if not pairs:
        return []
    return ["STAIR against the semantics-blind baselines, pooled over the scenes (the difference is STAIR minus "
            "the baseline): " + "; ".join(f"{c.other} on {c.metric}: **{STAIR_WORDS[c.verdict]}**" for c in pairs)
            + ".", "", "| scenes | metric | STAIR | baseline | paired difference | p | verdict |",
            "|---|---|---|---|---|---|---|", *[_line(c, STAIR_WORDS) for c in pairs], ""]


def markdown_report(by_level: dict[str, list[dict]]) -> str:
    """Per level: how many missions, then each utility variant against STAIR, pooled and per scene."""
    out = ["Scores: each seed's mean over the 10 steps; the paired difference is the variant minus STAIR over the "
           "(scene, seed) pairs both ran, ± the standard deviation of those differences; p from the paired t-test; a "
           "verdict needs p < 0.05 (and at least two pairs).", ""]
    header = ["| scenes | metric | variant | STAIR | paired difference | p | verdict |", "|---|---|---|---|---|---|---|"]
    for level in LEVELS:
        rows = by_level.get(level, [])
        counts = {v: len({(r["scene"], r["seed"]) for r in rows if r["variant"] == v}) for v in VARIANTS}
        out += [f"### Label noise {level}", "",
                "Finished missions: " + ", ".join(f"{v} {n}" for v, n in counts.items()) + ".", ""]
        table = []
        for variant in AGAINST_STAIR:
            for metric in METRICS:
                c = pooled(rows, metric, variant, "stair")
                if c is not None:
                    table += [_line(c)] + [_line(s) for s in per_scene(rows, metric, variant, "stair")]
        if not table:
            out += ["No pair of a utility variant and STAIR has finished yet.", "", *_baselines(rows)]
            continue
        verdicts = [f"{variant} on {metric}: **{WORDS[c.verdict]}**" for variant in AGAINST_STAIR for metric in METRICS
                    if (c := pooled(rows, metric, variant, "stair")) is not None]
        out += ["Pooled over the scenes: " + "; ".join(verdicts) + ".", "", *header, *table, "", *_baselines(rows)]
    return "\n".join(out)
