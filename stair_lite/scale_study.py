"""Lite against the paper's scale: which claim verdicts change with scale (RESULTS.md, "At the paper's scale";
notebook 06).

The paper-scale comparison (``scripts/paper_comparison.sh``, folder ``comparison_paper``) runs STAIR, Exploration,
the fixed spiral, Max View Distance and STE on the four paper scenes at the ``paper`` preset (a 128^3 field and
voxel map, 8000 rays and 200 iterations per view, 100 test views at 400 x 400); the lite comparison
(``comparison_lite``) ran them with the others at ``lite``. Both are tested as ``claims`` tests a study: per-seed
means over the steps, paired t-tests at ``claims.ALPHA``. Claim (i) compares STAIR at both scales with the same
baseline per scene and metric, the strongest at lite over all its seeds (among the baselines both studies ran), so a
column never changes its baseline and three noisy paper-scale seeds do not pick their own; claim (ii) is STAIR against
STE overall (the paper-scale study runs no cross-validation variants).

Per claim, scene and metric three paired comparisons stand side by side: lite over all its seeds, lite over as many
seeds as the paper-scale study finished there (the same seed numbers; the two scales' missions are not pairs, as their
maps differ and their views part after the first step: the column shows what a verdict with that few pairs says at
lite), and the paper scale. Whether the *effect* changes with scale is a test of its own: Welch's t-test between the
paired differences at the paper scale and at lite (all seeds). With about 50 such tests at the 5 % level, two or three
"changes" are expected by chance alone. Where the paper scale's verdict differs from lite's, ``verdict_change`` says how:
it flips, is new, is lost at the paper scale, or lite over the same seeds does not reach it either (which the fewer
seeds may explain; no cause is claimed).

Only the scores within a scale are compared: the two presets also evaluate differently (20 test views at 100 x 100 px
against 100 at 400 x 400, meshes from a 128^3 against a 256^3 lattice, 1e5 against 1e6 surface points), so an
absolute score at one scale is not the same measurement as at the other.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import stats

from .claims import ALPHA, TOO_FEW_PAIRS, Comparison, claim_one, compare, metrics_of, scenes_of, seeds_of
from .experiments import RESULTS_DIR, collect
from .metrics import METRICS

SCALES = {"lite": "comparison_lite", "paper": "comparison_paper"}  # scale -> its comparison's folder
VARIANTS = ("stair", "exploration", "fixed", "max_distance", "ste")  # what the paper-scale study runs
CLAIMS = {"(i)": "STAIR vs the strongest implicit baseline at lite", "(ii)": "STAIR vs STE"}
SHORT = {"holds": "holds", "reversed": "reversed", "not significant": "n.s.", TOO_FEW_PAIRS: TOO_FEW_PAIRS}


def scale_rows(root: Path = RESULTS_DIR, log=print) -> dict[str, list[dict]]:
    """Scale -> the finished missions of the shared variants in its comparison folder (an absent folder: none; a root
    with neither folder is refused)."""
    if not any((Path(root) / name).is_dir() for name in SCALES.values()):
        raise ValueError(f"{root} holds neither {' nor '.join(SCALES.values())}: name the folder of the stored results "
                         "(data/results)")
    out = {}
    for scale, name in SCALES.items():
        folder = Path(root) / name
        out[scale] = [r for r in collect(folder, log) if r["variant"] in VARIANTS] if folder.exists() else []
    return out


def seeds_by_scene(rows: list[dict]) -> dict[str, list[int]]:
    """Scene -> the seeds every shared variant finished there."""
    out = {}
    for scene in scenes_of(rows):
        ran = [{int(r["seed"]) for r in rows if (r["scene"], r["variant"]) == (scene, v)} for v in VARIANTS]
        if seeds := sorted(set.intersection(*ran)):
            out[scene] = seeds
    return out


def restricted(rows: list[dict], seeds: dict[str, list[int]]) -> list[dict]:
    """The rows of the given seeds per scene (other scenes left out)."""
    return [r for r in rows if int(r["seed"]) in seeds.get(r["scene"], ())]


def pooled(comparisons: list[Comparison]) -> Comparison:
    """One paired comparison over every (scene, seed) pair of per-scene comparisons of one claim and metric: each scene
    weighted by its pairs, its baseline kept ("strongest" where the scenes' differ). The spread between scenes counts as
    noise, and the pairs' degrees of freedom overstate what a few scenes support: read it beside the per-scene rows."""
    first = comparisons[0]
    others = sorted({c.other for c in comparisons})
    return Comparison("all scenes", first.metric, first.claimed, others[0] if len(others) == 1 else "strongest",
                      np.concatenate([c.claimed_scores for c in comparisons]),
                      np.concatenate([c.other_scores for c in comparisons]))


def opponents(lite_rows: list[dict]) -> dict[tuple[str, str, str], str]:
    """(claim, scene, metric) -> the variant STAIR is compared with at both scales: for claim (i) the strongest
    baseline at lite over all its seeds, for claim (ii) STE."""
    out = {("(i)", c.scene, c.metric): c.other for c in claim_one(lite_rows)}
    out.update({("(ii)", scene, metric): "ste" for scene in scenes_of(lite_rows) for metric in metrics_of(lite_rows)
                if seeds_of(lite_rows, scene, "ste")})
    return out


def side_by_side(by_scale: dict[str, list[dict]]) -> list[dict]:
    """One entry per claim, scene (and "all scenes", pooled over the seeds that every scene finished at the paper scale)
    and metric that the paper-scale study can test: STAIR against the same opponent (``opponents``) at lite over all its
    seeds (``lite``), at lite over the paper study's seed numbers (``lite_same``) and at the paper scale (``paper``)."""
    paper_seeds = seeds_by_scene(by_scale["paper"])
    lite = [r for r in by_scale["lite"] if r["scene"] in paper_seeds]
    if not paper_seeds or not lite:
        return []
    against = opponents(lite)
    # the pooled rows take only the seeds every scene finished, so that each scene weighs alike at both scales
    common = sorted(set.intersection(*(set(seeds) for seeds in paper_seeds.values())))
    balanced = {scene: common for scene in paper_seeds}
    columns = {"lite": lite, "lite_same": restricted(lite, paper_seeds), "paper": restricted(by_scale["paper"], paper_seeds)}
    pooled_columns = {"lite": lite, "lite_same": restricted(lite, balanced), "paper": restricted(by_scale["paper"], balanced)}
    metrics = [m for m in metrics_of(lite) if m in metrics_of(by_scale["paper"])]
    out = []
    for claim in CLAIMS:
        for metric in metrics:
            keys = [(claim, scene, metric) for scene in paper_seeds if (claim, scene, metric) in against]
            if not keys:
                continue
            out += [{"claim": claim, "scene": k[1], "metric": metric,
                     **{name: compare(rows, k[1], metric, "stair", against[k]) for name, rows in columns.items()}}
                    for k in keys]
            if common:
                out.append({"claim": claim, "scene": "all scenes", "metric": metric,
                            **{name: pooled([compare(rows, k[1], metric, "stair", against[k]) for k in keys])
                               for name, rows in pooled_columns.items()}})
    return out


def scale_effect(entry: dict) -> tuple[float, float]:
    """The paper scale's mean paired difference minus lite's (all seeds), and Welch's two-sided p for it (NaN with
    fewer than two pairs at either scale): does STAIR's advantage itself change with scale?"""
    paper, lite = entry["paper"].differences, entry["lite"].differences
    if len(paper) < 2 or len(lite) < 2 or (np.ptp(paper) == 0 and np.ptp(lite) == 0):
        return float(paper.mean() - lite.mean()), float("nan")
    return float(paper.mean() - lite.mean()), float(stats.ttest_ind(paper, lite, equal_var=False).pvalue)


def changes_with_scale(entry: dict) -> bool:
    """Welch's test finds STAIR's paired difference at the paper scale unlike lite's (p < ALPHA)."""
    return scale_effect(entry)[1] < ALPHA


DECIDED = ("holds", "reversed")
# how a verdict at the paper scale differs from lite's over all its seeds (``verdict_change``), in the report's order
CHANGES = {
    "flips": "decided at both scales, in opposite directions",
    "new at the paper scale": "not significant at lite, decided at the paper scale",
    "lost at the paper scale": "decided at lite over all its seeds and over the paper study's seeds alike, not significant "
                               "at the paper scale",
    "not reached over these seeds at lite either": "decided at lite over all its seeds; over the paper study's seeds "
                                                   "lite does not reach that verdict either, which the few seeds may explain",
}


def verdict_change(entry: dict) -> str | None:
    """How the paper scale's verdict differs from lite's over all seeds (a key of ``CHANGES``), or None: the same
    verdict, or too few pairs at either scale to have one. Lite over the paper study's seeds separates a verdict those
    seeds still reach at lite from one they do not (a matter of power, not a proof of cause)."""
    lite, same, paper = entry["lite"].verdict, entry["lite_same"].verdict, entry["paper"].verdict
    if TOO_FEW_PAIRS in (lite, paper) or paper == lite:
        return None
    if paper in DECIDED:
        return "flips" if lite in DECIDED else "new at the paper scale"
    return "lost at the paper scale" if same == lite else "not reached over these seeds at lite either"


def core_hours(rows: list[dict]) -> float:
    """The wall time of the missions' phases (plan, train, evaluate; measuring a view takes well under a second) summed,
    in hours: core-hours where each mission ran on one core (the sweeps' workers run torch on one thread; the mesh
    scores' nearest-distance queries may use every core)."""
    return sum(r["time_plan_s"] + r["time_train_s"] + r["time_evaluate_s"] for r in rows) / 3600


def scores(by_scale: dict[str, list[dict]], metric: str) -> dict[tuple[str, str], float]:
    """(scale, variant) -> the metric's mean over the steps, averaged over the paper study's finished (scene, seed)
    pairs that the scale ran (NaN: none). The scales evaluate differently: compare variants within a scale."""
    paper_seeds = seeds_by_scene(by_scale["paper"])
    out = {}
    for scale, rows in by_scale.items():
        for v in VARIANTS:
            values = [r[metric] for r in restricted(rows, paper_seeds) if r["variant"] == v]
            out[scale, v] = float(np.mean(values)) if values else float("nan")
    return out


def _cell(c: Comparison) -> str:
    d, p = METRICS[c.metric].digits, (f"{c.p_value:.3f}" if len(c.differences) >= 2 else "-")
    against = f" vs {c.other}" if c.other != "ste" else ""
    return f"{c.difference:+.{d}f}{against} (n={len(c.differences)}, p = {p}) {SHORT[c.verdict]}"


def _effect(entry: dict) -> str:
    delta, p = scale_effect(entry)
    d = METRICS[entry["metric"]].digits
    return f"{delta:+.{d}f} (p = {p:.3f}) " + ("**yes**" if p < ALPHA else "no") if np.isfinite(p) else f"{delta:+.{d}f} (-) {TOO_FEW_PAIRS}"


def _changes_line(entries: list[dict]) -> str:
    """Which verdicts differ between lite (all seeds) and the paper scale, by kind (``verdict_change``)."""
    decided = [e for e in entries if e["paper"].verdict != TOO_FEW_PAIRS]
    kinds = {kind: [e for e in decided if verdict_change(e) == kind] for kind in CHANGES}
    listed = "; ".join(
        f"**{kind}** ({CHANGES[kind]}): " + ", ".join(
            f"claim {e['claim']} {e['scene']} {e['metric']} ({SHORT[e['lite'].verdict]} -> {SHORT[e['paper'].verdict]})"
            for e in mine) for kind, mine in kinds.items() if mine)
    same = len(decided) - sum(map(len, kinds.values()))
    two = sum(len(e["paper"].differences) == 2 for e in decided)
    caveat = (f" {two} of them have only two pairs at the paper scale: a paired test with one degree of freedom needs t "
              f"above {stats.t.ppf(1 - ALPHA / 2, 1):.1f} for p < {ALPHA}, so there a verdict lost is mostly the test's "
              "power.") if two else ""
    return (f"Verdicts at the paper scale against lite's over all its seeds, among the {len(decided)} comparisons with two "
            f"pairs at the paper scale: {same} the same" + (f"; {listed}." if listed else ".") + caveat)


def verdict_map(entries: list[dict], claim: str) -> list[str]:
    """One claim's verdicts at a glance: a table of scenes (and the pool) by metrics, each cell lite's verdict over all
    its seeds and the paper scale's, ``lite -> paper``, in bold where they differ (``verdict_change``)."""
    mine = [e for e in entries if e["claim"] == claim]
    metrics = list(dict.fromkeys(e["metric"] for e in mine))
    scenes = sorted({e["scene"] for e in mine}, key=lambda s: (s == "all scenes", s))
    cells = {(e["scene"], e["metric"]): e for e in mine}

    def cell(e: dict | None) -> str:
        if e is None:
            return ""
        text = f"{SHORT[e['lite'].verdict]} -> {SHORT[e['paper'].verdict]}"
        return f"**{text}**" if verdict_change(e) else text

    return ["| scene | " + " | ".join(metrics) + " |", "|---|" + "---|" * len(metrics),
            *[f"| {s} | " + " | ".join(cell(cells.get((s, m))) for m in metrics) + " |" for s in scenes]]


def _missions(rows: list[dict]) -> int:
    return len({(r["scene"], r["variant"], r["seed"]) for r in rows})


def markdown_report(by_scale: dict[str, list[dict]]) -> str:
    """The study's state and compute, the variants' scores within each scale, then per claim the pooled and the
    per-scene comparisons at both scales and whether STAIR's difference changes with scale."""
    paper_seeds = seeds_by_scene(by_scale["paper"])
    state = ", ".join(f"{scene} seeds {', '.join(map(str, seeds))}" for scene, seeds in paper_seeds.items()) or "none yet"
    lite_shared = [r for r in by_scale["lite"] if r["variant"] in VARIANTS]
    out = ["Missions of the five shared variants (stair, exploration, fixed, max_distance, ste) finished at the paper "
           f"scale: {_missions(by_scale['paper'])}; seeds with all five finished: {state}. Compute: "
           f"{core_hours(by_scale['paper']):.1f} core-hours, {60 * core_hours(by_scale['paper']) / max(1, _missions(by_scale['paper'])):.0f} "
           f"minutes a mission; at lite {_missions(lite_shared)} missions, {core_hours(lite_shared):.1f} core-hours, "
           f"{60 * core_hours(lite_shared) / max(1, _missions(lite_shared)):.1f} minutes a mission.", ""]
    if not paper_seeds:
        return "\n".join(out + ["No scene has every shared variant finished at the paper scale yet.", ""])
    entries = side_by_side(by_scale)
    if not entries:
        return "\n".join(out + ["The lite comparison holds none of the scenes the paper scale finished.", ""])
    per_scene = [e for e in entries if e["scene"] != "all scenes"]
    changed = [e for e in per_scene if changes_with_scale(e)]
    tested = [e for e in per_scene if np.isfinite(scale_effect(e)[1])]
    pooled_tested = [e for e in entries if e["scene"] == "all scenes" and np.isfinite(scale_effect(e)[1])]
    pooled_changed = [e for e in pooled_tested if changes_with_scale(e)]
    few_seeds = [e for e in per_scene if len(e["lite_same"].differences) >= 2]
    seeds_only = [e for e in few_seeds if e["lite"].verdict != e["lite_same"].verdict]
    pooled_few = [e for e in entries if e["scene"] == "all scenes" and len(e["lite_same"].differences) >= 2]
    pooled_seeds_only = [e for e in pooled_few if e["lite"].verdict != e["lite_same"].verdict]
    shown = metrics_of(by_scale["lite"] + by_scale["paper"])
    means = {m: scores(by_scale, m) for m in ("psnr", "psnr_clean", "f1", "chamfer") if m in shown}
    out += ["Each variant's mean over the steps, averaged over those scenes and seeds, at lite too (its missions of the "
            "same scenes and seed numbers; compare the variants within a scale: the two scales also evaluate differently):",
            "",
            "| variant | " + " | ".join(f"{m} lite | {m} paper" for m in means) + " |", "|---|" + "---|---|" * len(means),
            *[f"| {v} | " + " | ".join(f"{means[m]['lite', v]:.{METRICS[m].digits}f} | {means[m]['paper', v]:.{METRICS[m].digits}f}"
                                       for m in means) + " |" for v in VARIANTS], ""]
    out += [f"STAIR's paired difference changes with scale (Welch's test against lite's, p < {ALPHA}) in {len(changed)} of "
            f"the {len(tested)} per-scene comparisons that have two pairs at the paper scale (about {ALPHA * len(tested):.1f} "
            f"expected by chance alone), and in {len(pooled_changed)} of the {len(pooled_tested)} pooled over the scenes "
            "(\"all scenes\", over the seeds every scene finished: a pair is a scene's seed, so with few seeds a scene "
            "their spread is mostly the scenes', and the pooled tests share their missions across the metrics: read "
            "their p-values as optimistic); lite's own verdict over only the paper study's seeds differs from its verdict "
            f"over all seeds in {len(seeds_only)} of the {len(few_seeds)} per-scene comparisons with two such seeds and in "
            f"{len(pooled_seeds_only)} of the {len(pooled_few)} pooled ones. Each cell: the paired "
            "difference (STAIR minus the other), the pairs, p and the verdict (n.s.: not significant; "
            f"{TOO_FEW_PAIRS}: fewer than two); the last column the paper scale's difference minus lite's.", ""]
    out += [_changes_line(entries), ""]
    for claim, what in CLAIMS.items():
        out += [f"Claim {claim} at a glance ({what}; lite over all its seeds -> the paper scale, in bold where they "
                "differ):", "", *verdict_map(entries, claim), ""]
    for claim, what in CLAIMS.items():
        mine = [e for e in entries if e["claim"] == claim]
        out += [f"### Claim {claim}: {what}", "",
                "| scene | metric | lite, all seeds | lite, as many seeds as the paper scale | paper scale | "
                "changes with scale |", "|---|---|---|---|---|---|"]
        for e in sorted(mine, key=lambda e: (e["scene"] != "all scenes", e["scene"])):
            out.append(f"| {e['scene']} | {e['metric']} | {_cell(e['lite'])} | {_cell(e['lite_same'])} | "
                       f"{_cell(e['paper'])} | {_effect(e)} |")
        out.append("")
    return "\n".join(out)
