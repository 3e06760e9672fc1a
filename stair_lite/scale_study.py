"""Lite against the paper's scale: which claim verdicts change with scale (RESULTS.md, "At the paper's scale";
notebook 06).

The paper-scale comparison (``scripts/paper_comparison.sh``, folder ``comparison_paper``) runs STAIR, Exploration,
the fixed spiral, Max View Distance and STE on the four paper scenes at the ``paper`` preset (a 128^3 field and
voxel map, 8000 rays and 200 iterations per view, 100 test views at 400 x 400); the lite comparison
(``comparison_lite``) ran them with the others at ``lite``. Both are tested as ``claims`` tests a study: per-seed
means over the steps, paired t-tests at ``claims.ALPHA``. Claim (i) picks STAIR's strongest baseline among the
baselines *both* studies ran, so the two scales answer the same question; claim (ii) is STAIR against STE (the
paper-scale study runs no cross-validation variants).

Three verdicts stand side by side: lite over all its seeds, lite over the seeds the paper-scale study finished (the
same number of pairs: a verdict that changes only with fewer seeds is the seeds', not the scale's), and the paper
scale. A verdict "changes with scale" when the paper scale's differs from lite's over the same seeds.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .claims import Comparison, claim_one, claim_two, metrics_of, scenes_of
from .experiments import RESULTS_DIR, collect
from .metrics import METRICS

SCALES = {"lite": "comparison_lite", "paper": "comparison_paper"}  # scale -> its comparison's folder
VARIANTS = ("stair", "exploration", "fixed", "max_distance", "ste")  # what the paper-scale study runs
CLAIMS = {"(i)": "STAIR vs its strongest implicit baseline", "(ii)": "STAIR vs STE"}
SHORT = {"holds": "holds", "reversed": "reversed", "not significant": "n.s."}


def scale_rows(root: Path = RESULTS_DIR, log=print) -> dict[str, list[dict]]:
    """Scale -> the finished missions of the shared variants in its comparison folder (an absent folder: none)."""
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


def verdicts(rows: list[dict]) -> dict[tuple[str, str, str], Comparison]:
    """(claim, scene, metric) -> the comparison, for claims (i) (among ``VARIANTS``' baselines) and (ii) overall."""
    out = {("(i)", c.scene, c.metric): c for c in claim_one(rows)}
    out.update({("(ii)", c.scene, c.metric): c for c in claim_two(rows)["overall"]})
    return out


def pooled(comparisons: list[Comparison]) -> Comparison:
    """One comparison over every (scene, seed) pair of per-scene comparisons of one claim and metric."""
    first = comparisons[0]
    others = sorted({c.other for c in comparisons})
    return Comparison("all scenes", first.metric, first.claimed, others[0] if len(others) == 1 else "strongest",
                      np.concatenate([c.claimed_scores for c in comparisons]),
                      np.concatenate([c.other_scores for c in comparisons]))


def side_by_side(by_scale: dict[str, list[dict]]) -> list[dict]:
    """One entry per claim, scene (and "all scenes", pooled) and metric that the paper-scale study can test: the
    comparison at lite over all its seeds (``lite``), at lite over the paper study's seeds (``lite_same``) and at
    the paper scale (``paper``)."""
    paper_seeds = seeds_by_scene(by_scale["paper"])
    lite = [r for r in by_scale["lite"] if r["scene"] in paper_seeds]
    columns = {"lite": verdicts(lite), "lite_same": verdicts(restricted(lite, paper_seeds)),
               "paper": verdicts(restricted(by_scale["paper"], paper_seeds))}
    metrics = [m for m in metrics_of(lite) if m in metrics_of(by_scale["paper"])] if paper_seeds else []
    out = []
    for claim in CLAIMS:
        for metric in metrics:
            keys = [(claim, scene, metric) for scene in paper_seeds]
            if not all(k in column for column in columns.values() for k in keys):
                continue
            out += [{"claim": claim, "scene": k[1], "metric": metric, **{n: c[k] for n, c in columns.items()}} for k in keys]
            out.append({"claim": claim, "scene": "all scenes", "metric": metric,
                        **{n: pooled([c[k] for k in keys]) for n, c in columns.items()}})
    return out


def changes_with_scale(entry: dict) -> bool:
    """The paper scale's verdict differs from lite's over the same seeds."""
    return entry["paper"].verdict != entry["lite_same"].verdict


def core_hours(rows: list[dict]) -> float:
    """The compute the missions' phases took (plan, train, evaluate), in core-hours (each mission ran one thread)."""
    return sum(r["time_plan_s"] + r["time_train_s"] + r["time_evaluate_s"] for r in rows) / 3600


def scores(by_scale: dict[str, list[dict]], metric: str) -> dict[tuple[str, str], float]:
    """(scale, variant) -> the metric's mean over the steps, averaged over the paper study's finished (scene, seed)
    pairs: what the scale buys each planner."""
    paper_seeds = seeds_by_scene(by_scale["paper"])
    return {(scale, v): float(np.mean([r[metric] for r in restricted(rows, paper_seeds) if r["variant"] == v]))
            for scale, rows in by_scale.items() for v in VARIANTS}


def _cell(c: Comparison) -> str:
    d, p = METRICS[c.metric].digits, (f"{c.p_value:.3f}" if len(c.differences) >= 2 else "-")
    against = f" vs {c.other}" if c.other != "ste" else ""
    return f"{c.difference:+.{d}f}{against} (n={len(c.differences)}, p {p}) {SHORT[c.verdict]}"


def _missions(rows: list[dict]) -> int:
    return len({(r["scene"], r["variant"], r["seed"]) for r in rows})


def markdown_report(by_scale: dict[str, list[dict]]) -> str:
    """The study's state and compute, then per claim the pooled verdicts and the per-scene ones at both scales."""
    paper_seeds = seeds_by_scene(by_scale["paper"])
    state = ", ".join(f"{scene} seeds {', '.join(map(str, seeds))}" for scene, seeds in paper_seeds.items()) or "none yet"
    lite_shared = [r for r in by_scale["lite"] if r["variant"] in VARIANTS]
    out = ["Missions of the five shared variants (stair, exploration, fixed, max_distance, ste) finished at the paper "
           f"scale: {_missions(by_scale['paper'])}; seeds with all five finished: {state}. Compute: "
           f"{core_hours(by_scale['paper']):.1f} core-hours, {60 * core_hours(by_scale['paper']) / max(1, _missions(by_scale['paper'])):.0f} "
           f"minutes a mission; at lite {_missions(lite_shared)} missions, {core_hours(lite_shared):.1f} core-hours, "
           f"{60 * core_hours(lite_shared) / max(1, _missions(lite_shared)):.1f} minutes a mission.", ""]
    entries = side_by_side(by_scale)
    if not entries:
        return "\n".join(out + ["No scene has every shared variant finished at the paper scale yet.", ""])
    changed = [e for e in entries if e["scene"] != "all scenes" and changes_with_scale(e)]
    per_scene = [e for e in entries if e["scene"] != "all scenes"]
    seeds_only = [e for e in per_scene if e["lite"].verdict != e["lite_same"].verdict]
    shown = metrics_of(by_scale["lite"] + by_scale["paper"])
    means = {m: scores(by_scale, m) for m in ("psnr", "psnr_clean", "f1", "chamfer") if m in shown}
    out += ["Each variant's mean over the steps, averaged over those scenes and seeds, at lite and at the paper scale:", "",
            "| variant | " + " | ".join(f"{m} lite | {m} paper" for m in means) + " |", "|---|" + "---|---|" * len(means),
            *[f"| {v} | " + " | ".join(f"{means[m]['lite', v]:.{METRICS[m].digits}f} | {means[m]['paper', v]:.{METRICS[m].digits}f}"
                                       for m in means) + " |" for v in VARIANTS], ""]
    out += [f"Per scene and metric, the paper scale's verdict differs from lite's over the same seeds in {len(changed)} "
            f"of {len(per_scene)} comparisons; lite's own verdict changes with only the paper study's seeds in "
            f"{len(seeds_only)}. Each cell: the paired difference (claimed minus other), the pairs, p and the verdict "
            "(n.s.: not significant).", ""]
    for claim, what in CLAIMS.items():
        mine = [e for e in entries if e["claim"] == claim]
        out += [f"### Claim {claim}: {what}", "",
                "| scene | metric | lite, all seeds | lite, the paper study's seeds | paper scale | changes with scale |",
                "|---|---|---|---|---|---|"]
        for e in sorted(mine, key=lambda e: (e["scene"] != "all scenes", e["scene"])):
            out.append(f"| {e['scene']} | {e['metric']} | {_cell(e['lite'])} | {_cell(e['lite_same'])} | "
                       f"{_cell(e['paper'])} | {'**yes**' if changes_with_scale(e) else 'no'} |")
        out.append("")
    return "\n".join(out)
