"""A variant run in its own results folder, paired over seeds with the variants of a stored comparison: per scene and
pooled over the scenes (a pair per scene and seed), each metric's mean over the steps, with the paired t-test of
``claims``; then each variant's view spread (the mean angle between two of a mission's views, median over the seeds),
the median elevation of its views after the first, and the median angle from a view to the nearest earlier view of its
mission. A seed gives every variant the same field initialisation and
first view, so the variant's missions pair with the stored ones of the same scene and seed.

Run: .venv/bin/python benchmarks/paired_variant.py --variant stair_volume --results data/results/volume_lite
     [--against data/results/comparison_lite] [--others stair,fixed,exploration]
(RESULTS.md, "The unknown only within the volume to reconstruct".)
"""
import argparse

import numpy as np

import stair_lite  # noqa: F401
from stair_lite.claims import compare, metrics_of, scenes_of
from stair_lite.experiments import collect
from stair_lite.geometry import angular_distance, view_spread
from stair_lite.metrics import METRICS


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--variant", required=True)
    parser.add_argument("--results", required=True, help="the folder of the variant's missions")
    parser.add_argument("--against", default="data/results/comparison_lite", help="the stored comparison")
    parser.add_argument("--others", default="stair,fixed,exploration")
    args = parser.parse_args()
    mine = [r for r in collect(args.results, log=lambda m: None) if r["variant"] == args.variant]
    pairs = {(r["scene"], r["seed"]) for r in mine}
    # the variant's own missions once, even where --results is the stored comparison itself
    rows = mine + [r for r in collect(args.against, log=lambda m: None)
                   if (r["scene"], r["seed"]) in pairs and r["variant"] != args.variant]
    scenes, others = scenes_of(mine), args.others.split(",")
    # pooled: every (scene, seed) one pair
    pooled = [dict(r, scene="all scenes", seed=1000 * scenes.index(r["scene"]) + r["seed"]) for r in rows]
    print(f"{args.variant}: {len(pairs)} missions finished ({', '.join(f'{s} {sum(p[0] == s for p in pairs)}' for s in scenes)})")
    print(f"paired differences ({args.variant} minus the other; mean over the steps); pooled: n, p and verdict; per scene: "
          "the difference and its verdict")
    for other in others:
        for metric in metrics_of(rows):
            c = compare(pooled, "all scenes", metric, args.variant, other)
            d = METRICS[metric].digits
            per_scene = [compare(rows, s, metric, args.variant, other) for s in scenes]
            print(f"vs {other:12s} {metric:10s} all scenes {c.difference:+.{d}f} (n={len(c.differences)}, "
                  f"p = {c.p_value:.3f}) {c.verdict} | " +
                  " | ".join(f"{s}: {x.difference:+.{d}f} {x.verdict}" for s, x in zip(scenes, per_scene)))
    for variant in [args.variant, *others]:
        spread, elevation, nearest = [], [], []
        for scene in scenes:
            missions = [sorted((r for r in rows if (r["scene"], r["variant"], r["seed"]) == (scene, variant, seed)),
                               key=lambda r: r["step"]) for seed in sorted(s for sc, s in pairs if sc == scene)]
            views = [np.radians([[r["elevation_deg"], r["azimuth_deg"]] for r in m]) for m in missions if len(m) > 1]
            spread.append(np.median([np.degrees(view_spread(v)) for v in views]))
            elevation.append(np.median([r["elevation_deg"] for m in missions for r in m[1:]]))
            # how near each new view lands to the mission's earlier ones
            nearest.extend(np.degrees(angular_distance(v, v)[i, :i].min()) for v in views for i in range(1, len(v)))
        print(f"{variant:12s} view spread [deg] " + ", ".join(f"{v:.0f}" for v in spread) +
              "; median elevation after the first view [deg] " + ", ".join(f"{v:.0f}" for v in elevation) +
              f"; median angle to the nearest earlier view, all scenes {np.median(nearest):.0f} deg")


if __name__ == "__main__":
    main()
