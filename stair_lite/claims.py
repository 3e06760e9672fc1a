"""The paper's three claims (Sec. I), checked against stored sweep results.

Introduced in notebook 06. Every comparison is between two variants' *per-seed* scores, a metric's
mean over the 10 steps (the area under its curve divided by the steps; it rewards reaching a good
reconstruction early). The design is paired: a seed gives every planner the same field initialisation
and the same first (top) view, so the test is a paired t-test (two-sided, at ``ALPHA``) on the per-seed
differences over the seeds both variants ran:

* claim (i): STAIR against the strongest of the implicit baselines (exploration, fixed, max_distance,
  uniform), per scene and metric;
* claim (ii): STAIR against STE, split as the paper splits it: mapping (STE's views, implicit vs
  explicit map: ``ste_implicit`` vs ``ste``) and planning (the explicit map, STAIR's vs STE's views:
  ``stair_explicit`` vs ``ste``);
* claim (iii): on an ablation scene, epsilon > 0 against exploitation alone (epsilon = 0), plus
  whether each mission ever saw the occluded chair.

A verdict is "holds" (the claimed side is better, p < ALPHA), "reversed" (the other side is better,
p < ALPHA), "not significant", or "too few pairs" (one seed: no spread to test against). Better is higher, except
for the chamfer distance. ``seeds_needed`` gives the number of seeds a paired test needs to detect a difference of a
given size.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from .experiments import epsilon_of
from .geometry import Intrinsics
from .metrics import METRICS, compared_metrics
from .scenes import build_scene, load_scene_spec
from .simulator import Simulator

ALPHA = 0.05
TOO_FEW_PAIRS = "too few pairs"  # the verdict over one seed: no spread to test against
VERDICTS = ("holds", "not significant", "reversed", TOO_FEW_PAIRS)
IMPLICIT_BASELINES = ("exploration", "fixed", "max_distance", "uniform")


def metrics_of(rows) -> tuple[str, ...]:
    """The compared metrics (metrics.py) every row has (a metric registered after a mission ran is missing there)."""
    return tuple(m for m in compared_metrics() if all(r.get(m) is not None for r in rows))


def seeds_of(rows, scene: str, variant: str) -> list[int]:
    return sorted({int(r["seed"]) for r in rows if (r["scene"], r["variant"]) == (scene, variant)})


def per_seed_scores(rows: list[dict], scene: str, variant: str, metric: str, step: int | None = None,
                    seeds: list[int] | None = None) -> np.ndarray:
    """One number per seed (all of the variant's seeds, or ``seeds`` in that order): the metric's mean over
    the mission's steps, or its value at ``step``."""
    seeds = seeds_of(rows, scene, variant) if seeds is None else seeds
    if not seeds:
        raise ValueError(f"no results for variant {variant!r} on scene {scene!r}")
    return np.array([np.mean([r[metric] for r in rows if (r["scene"], r["variant"], r["seed"]) == (scene, variant, s)
                              and step in (None, r["step"])]) for s in seeds])


@dataclass(frozen=True)
class Comparison:
    """Is ``claimed`` better than ``other`` on ``metric`` in ``scene``? Per-seed scores of each, paired: entry k
    of both comes from the same seed."""

    scene: str
    metric: str
    claimed: str
    other: str
    claimed_scores: np.ndarray
    other_scores: np.ndarray

    def __post_init__(self):
        if len(self.claimed_scores) != len(self.other_scores):
            raise ValueError(f"a paired comparison needs one score per seed on both sides, got "
                             f"{len(self.claimed_scores)} and {len(self.other_scores)}")

    @property
    def differences(self) -> np.ndarray:
        """Per seed: claimed minus other."""
        return self.claimed_scores - self.other_scores

    @property
    def difference(self) -> float:
        return float(self.differences.mean())

    def interval(self, level: float = 0.95) -> tuple[float, float]:
        """The ``level`` confidence interval of the mean paired difference (Student's t over the seeds): the paired
        test finds a difference exactly when the 95 % interval leaves out 0."""
        d = self.differences
        half = stats.t.ppf(0.5 + level / 2, len(d) - 1) * d.std(ddof=1) / np.sqrt(len(d)) if len(d) > 1 else np.inf
        return float(d.mean() - half), float(d.mean() + half)

    @property
    def p_value(self) -> float:
        """Paired two-sided t-test; NaN with fewer than two seeds or identical differences."""
        d = self.differences
        if len(d) < 2 or np.ptp(d) == 0:
            return float("nan")
        return float(stats.ttest_rel(self.claimed_scores, self.other_scores).pvalue)

    @property
    def verdict(self) -> str:
        """"holds" or "reversed" (p < ALPHA, by the sign of the difference), "not significant", or ``TOO_FEW_PAIRS``
        with fewer than two pairs (no spread to test against)."""
        if len(self.differences) < 2:
            return TOO_FEW_PAIRS
        if not self.p_value < ALPHA:
            return "not significant"
        return "holds" if (self.difference > 0) != METRICS[self.metric].lower_is_better else "reversed"

    def describe(self) -> str:
        a, b, d = self.claimed_scores, self.other_scores, METRICS[self.metric].digits
        return (f"{self.scene} {self.metric}: {self.claimed} {a.mean():.{d}f} +- {a.std():.{d}f} vs "
                f"{self.other} {b.mean():.{d}f} +- {b.std():.{d}f} (paired over {len(a)} seeds, difference "
                f"{self.difference:+.{d}f}, p = {self.p_value:.3f}): {self.verdict}")


def compare(rows, scene, metric, claimed, other, step: int | None = None) -> Comparison:
    """The paired comparison over the seeds both variants ran."""
    seeds = sorted(set(seeds_of(rows, scene, claimed)) & set(seeds_of(rows, scene, other)))
    if not seeds:
        raise ValueError(f"variants {claimed!r} and {other!r} share no seed on scene {scene!r}")
    return Comparison(scene, metric, claimed, other, per_seed_scores(rows, scene, claimed, metric, step, seeds),
                      per_seed_scores(rows, scene, other, metric, step, seeds))


def seeds_needed(sd_difference: float, difference: float, alpha: float = ALPHA, power: float = 0.8,
                 most: int = 1000) -> int:
    """The fewest seeds with which a paired two-sided t-test at ``alpha`` detects a true mean difference of
    ``difference`` with probability ``power``, when per-seed differences spread with ``sd_difference``
    (the noncentral t distribution)."""
    if not sd_difference > 0 or difference == 0:
        raise ValueError(f"need a positive spread and a non-zero difference, got sd {sd_difference!r}, "
                         f"difference {difference!r}")
    effect = abs(difference) / sd_difference
    for n in range(2, most + 1):
        t_crit = stats.t.ppf(1 - alpha / 2, n - 1)
        # the far tail (the wrong sign) is negligible here, and scipy's nct returns NaN for it where it underflows
        wrong_sign = np.nan_to_num(stats.nct.cdf(-t_crit, n - 1, effect * np.sqrt(n)))
        reached = stats.nct.sf(t_crit, n - 1, effect * np.sqrt(n)) + wrong_sign
        if reached >= power:
            return n
    raise ValueError(f"more than {most} seeds needed for a difference of {difference} at spread {sd_difference}")


def scenes_of(rows) -> list[str]:
    return sorted({r["scene"] for r in rows})


def baselines_of(rows, scene: str) -> tuple[str, ...]:
    """The implicit baselines that ran on ``scene`` with a seed STAIR ran (a study may leave some out: the paper-scale
    comparison runs exploration, fixed and max_distance)."""
    return tuple(v for v in IMPLICIT_BASELINES if set(seeds_of(rows, scene, v)) & set(seeds_of(rows, scene, "stair")))


def claim_one(rows) -> list[Comparison]:
    """Claim (i): per scene and metric, STAIR against the implicit baseline with the best mean (lowest chamfer),
    among the baselines the study ran on that scene (a scene without STAIR or any of them is left out)."""
    out = []
    for scene in scenes_of(rows):
        if not (baselines := baselines_of(rows, scene)):
            continue
        for metric in metrics_of(rows):
            sign = -1 if METRICS[metric].lower_is_better else 1
            strongest = max(baselines, key=lambda v: sign * per_seed_scores(rows, scene, v, metric).mean())
            out.append(compare(rows, scene, metric, "stair", strongest))
    return out


CLAIM_TWO_PARTS = {"overall": ("stair", "ste"), "mapping": ("ste_implicit", "ste"), "planning": ("stair_explicit", "ste")}


def claim_two(rows, step: int | None = None) -> dict[str, list[Comparison]]:
    """Claim (ii): STAIR vs STE overall, and the paper's split into mapping and planning (means over the steps, or
    the values at ``step``); a part is compared on the scenes where both of its variants share a seed (none: empty)."""
    return {name: [compare(rows, scene, metric, a, b, step) for scene in scenes_of(rows)
                   if set(seeds_of(rows, scene, a)) & set(seeds_of(rows, scene, b)) for metric in metrics_of(rows)]
            for name, (a, b) in CLAIM_TWO_PARTS.items()}


def claim_three(rows, exploit_only: str = "stair_eps0", step: int | None = None) -> list[Comparison]:
    """Claim (iii): every epsilon > 0 against exploitation alone, on each metric (means over the
    steps, or the values at ``step``)."""
    (scene,) = scenes_of(rows)
    others = sorted({r["variant"] for r in rows} - {exploit_only}, key=epsilon_of)
    return [compare(rows, scene, metric, v, exploit_only, step) for v in others for metric in metrics_of(rows)]


def _simulators(spec, kept_objects, intrinsics: Intrinsics) -> tuple[Simulator, Simulator]:
    """Simulators of a scene spec as it is and with only ``kept_objects`` (the ground stays in both)."""
    return (Simulator(build_scene(spec), intrinsics),
            Simulator(build_scene(replace(spec, objects=tuple(kept_objects))), intrinsics))


def object_pixels(scene_name: str, index: int, views: np.ndarray, intrinsics: Intrinsics | None = None) -> np.ndarray:
    """How many pixels of each view (elevation, azimuth) see object ``index`` of a scene: the pixels whose
    nearest surface is that object's, i.e. whose depth would change if it were removed."""
    spec = load_scene_spec(scene_name)
    if not 0 <= index < len(spec.objects):
        raise ValueError(f"scene {scene_name!r} has objects 0..{len(spec.objects) - 1}, got index {index}")
    sim = Simulator(build_scene(spec), intrinsics or Intrinsics.from_fov(100, 100))
    return np.array([int((sim.objects_seen(elevation, azimuth) == index).sum())
                     for elevation, azimuth in np.asarray(views, dtype=float).reshape(-1, 2)])


def hidden_target_fraction(scene_name: str, views: np.ndarray, intrinsics: Intrinsics | None = None) -> float:
    """Of the pixels that show a target when the target objects stand alone, the fraction that other
    objects hide in the full scene, over the given views. The target-only ground truth (visible target
    pixels) leaves these white, while a map's target-only render deletes the occluders and shows them."""
    spec = load_scene_spec(scene_name)
    targets = spec.targets
    full, alone = _simulators(spec, [o for o in spec.objects if o.cls in targets], intrinsics or Intrinsics.from_fov(100, 100))
    visible = total = 0
    for elevation, azimuth in np.asarray(views, dtype=float).reshape(-1, 2):
        visible += int(np.isin(full.render_view(elevation, azimuth).labels, targets).sum())
        total += int(np.isin(alone.render_view(elevation, azimuth).labels, targets).sum())
    return 1.0 - visible / total if total else 0.0


def tally(comparisons: list[Comparison]) -> dict[str, int]:
    """How many comparisons got each verdict."""
    verdicts = [c.verdict for c in comparisons]
    return {v: verdicts.count(v) for v in VERDICTS}


HIDDEN_CHAIR = {"ablation_two_chairs": 2, "ablation_hidden_chair": 2}  # ablation scene -> index of its occluded chair
MIN_PIXELS = 20  # of 100 x 100: "the mission saw the object" (a sliver at a silhouette does not count)


def first_sight(rows, min_pixels: int = MIN_PIXELS) -> dict[tuple[str, int], int | None]:
    """(variant, seed) -> the first step whose view shows at least ``min_pixels`` of the ablation scene's
    occluded chair (None: never), for the one ablation scene of ``rows``."""
    (scene,) = scenes_of(rows)
    if scene not in HIDDEN_CHAIR:
        raise ValueError(f"{scene!r} is not an ablation scene; known: {', '.join(HIDDEN_CHAIR)}")
    missions = {key: sorted((r for r in rows if (r["variant"], int(r["seed"])) == key), key=lambda r: r["step"])
                for key in sorted({(r["variant"], int(r["seed"])) for r in rows})}
    # every distinct view once (all missions share their top view), rendered by one pair of simulators
    views, where = np.unique([[r["elevation_deg"], r["azimuth_deg"]] for mine in missions.values() for r in mine],
                             axis=0, return_inverse=True)
    seen_at = (object_pixels(scene, HIDDEN_CHAIR[scene], np.radians(views)) >= min_pixels)[where.reshape(-1)]
    out, start = {}, 0
    for key, mine in missions.items():
        seen = np.flatnonzero(seen_at[start:start + len(mine)])
        out[key] = int(mine[seen[0]]["step"]) if len(seen) else None
        start += len(mine)
    return out


def _table(comparisons: list[Comparison]) -> list[str]:
    lines = ["| scene | metric | claimed side | other side | paired difference | p | verdict |", "|---|---|---|---|---|---|---|"]
    for c in comparisons:
        a, b, d = c.claimed_scores, c.other_scores, METRICS[c.metric].digits
        lines.append(f"| {c.scene} | {c.metric} | {c.claimed} {a.mean():.{d}f} ± {a.std():.{d}f} | "
                     f"{c.other} {b.mean():.{d}f} ± {b.std():.{d}f} | {c.difference:+.{d}f} ± {c.differences.std():.{d}f} "
                     f"(n={len(a)}) | {f'{c.p_value:.3f}' if len(a) >= 2 else '-'} | {c.verdict} |")
    return lines


def _count(comparisons: list[Comparison]) -> str:
    t = tally(comparisons)
    return (f"holds in {t['holds']} of {len(comparisons)}, reversed in {t['reversed']}, not significant in "
            f"{t['not significant']}" + (f", {TOO_FEW_PAIRS} in {t[TOO_FEW_PAIRS]}" if t[TOO_FEW_PAIRS] else ""))


def markdown_report(rows, ablation_rows=None, sight: dict | None = None) -> str:
    """The claim-by-claim verdict as Markdown, computed from a sweep's rows (and the ablation's); ``sight``: the
    ablation's ``first_sight``, where it is already computed (it renders every view of every mission)."""
    out = ["Scores: each seed's mean over the 10 steps (the area under the curve over the steps); ± is the std over "
           "seeds; the paired difference is over the seeds both sides ran (same field initialisation and first view); "
           f"p from the paired t-test; a verdict needs p < {ALPHA}; lower chamfer is better.", "",
           "### Claim (i): STAIR beats the implicit baselines that ignore semantics", "",
           *(["STAIR against the strongest baseline (best mean: highest, lowest for chamfer) per scene and metric: " + _count(one) + ".", "",
              *_table(one)] if (one := claim_one(rows)) else
             ["No scene has STAIR and an implicit baseline finished on a shared seed (not run, or not finished yet)."]),
           ""]
    two = claim_two(rows)
    out += ["### Claim (ii): STAIR beats the explicit STE, in mapping and in planning", ""]
    for name, explain in (("overall", "STAIR vs STE"), ("mapping", "the same STE views on the implicit vs the explicit map"),
                          ("planning", "the explicit map fed STAIR's vs STE's views")):
        if two[name]:
            out += [f"**{name}** ({explain}): {_count(two[name])}.", "", *_table(two[name]), ""]
        else:
            out += [f"**{name}** ({explain}): no scene has {' and '.join(CLAIM_TWO_PARTS[name])} finished on a shared "
                    "seed (not run in this study, or not finished yet).", ""]
    last = max((int(r["step"]) for r in rows), default=0)
    final = claim_two(rows, step=last)
    if final["overall"]:
        out += [f"The same with each seed's value at the last step ({last}) instead of the mean over steps (a map that "
                "starts well but stops improving wins the mean and can lose the end): "
                + "; ".join(f"{name} {_count(final[name])}" for name in final if final[name]) + ". Overall:", "",
                *_table(final["overall"]), ""]
    if ablation_rows:
        three = claim_three(ablation_rows)
        out += ["### Claim (iii): exploration is needed to find an occluded target", "",
                "Each epsilon > 0 against exploitation alone (epsilon = 0) on the ablation scene: " + _count(three) + ".",
                "", *_table(three), ""]
        last = max(int(r["step"]) for r in ablation_rows)
        final = claim_three(ablation_rows, step=last)
        out += [f"The same with each seed's value at the last step ({last}) instead of the mean over steps: "
                + _count(final) + ".", "", *_table(final), ""]
        sight = first_sight(ablation_rows) if sight is None else sight
        out += ["Missions that saw the occluded chair (at least "
                f"{MIN_PIXELS} of 100 x 100 pixels in some view), and the first step they did:", ""]
        for variant in sorted({v for v, _ in sight}, key=epsilon_of):
            steps = [sight[k] for k in sorted(sight) if k[0] == variant]
            found = [s for s in steps if s is not None]
            out.append(f"- {variant}: {len(found)} of {len(steps)} missions; first sight at steps {found}")
        out.append("")
    return "\n".join(out)
