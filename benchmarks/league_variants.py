"""The utility variants tried for a map that marks the unknown (README, "The league of utilities"), scored on stored
headroom tables without realising anything again.

Run: .venv/bin/python benchmarks/league_variants.py data/results/headroom_league_lite [--out variants.json]
(or a part of the tables' .json files per process, each with its --out, then --summarise those files)
For each table the seeded mission is run again (it is deterministic), every variant scores the table's spread views
(stream 0), and per metric it prints, averaged over the tables: Spearman's correlation of the variant with the realised
gain, the share of spread views that the variant's top-ranked spread view beats (its "spread pick"; the league's pick
percentile realises the planner's own two-stage pick instead), and the correlation with the gain averaged over the
training streams. Variants are planners with other ``UtilityOptions`` (and, for the coverage and Fisher utilities, the
incidence weighting), plus three rank sums.
"""
import argparse
import json
from pathlib import Path

import numpy as np
from scipy.stats import rankdata

import stair_lite  # noqa: F401
from stair_lite.config import PlanConfig
from stair_lite.headroom import Headroom, rank_correlation, table_state
from stair_lite.planners import CoveragePlanner, FisherPlanner, UtilityPlanner
from stair_lite.utility import UtilityOptions

UNKNOWN = {"unknown_occupancy": PlanConfig.unknown_occupancy,  # lite's marking of the unknown
           "unknown_target_radius": PlanConfig.unknown_target_radius}
UNMARKED = {"unknown_occupancy": 0.0, "unknown_target_radius": 0.0}  # the rule before the league
VARIANTS = {  # name: (planner class, UtilityOptions beside epsilon 0.2 and the unknown unmarked, exploration only,
    #               incidence weighting)
    "stair unmarked": (UtilityPlanner, {}, False, False),
    "exploration unmarked": (UtilityPlanner, {}, True, False),
    "reference rule": (UtilityPlanner, {"delete_background": True, "saturating_rays": True, "min_ray_opacity": 0.01,
                                        "min_occupancy": 0.01}, False, False),
    "unknown 0.3, 20 cm": (UtilityPlanner, {"unknown_occupancy": 0.3, "unknown_target_radius": 0.2}, False, False),
    "unknown 0.5, 20 cm": (UtilityPlanner, UNKNOWN, False, False),
    "unknown 0.5, 30 cm": (UtilityPlanner, {"unknown_occupancy": 0.5, "unknown_target_radius": 0.3}, False, False),
    "unknown 0.7, 20 cm": (UtilityPlanner, {"unknown_occupancy": 0.7, "unknown_target_radius": 0.2}, False, False),
    "unknown, epsilon 1": (UtilityPlanner, {**UNKNOWN, "epsilon": 1.0}, False, False),
    "unknown, soft mask": (UtilityPlanner, {**UNKNOWN, "soft_mask": True}, False, False),
    "unknown, U_er only": (UtilityPlanner, {"unknown_occupancy": 0.5}, True, False),
    "coverage": (CoveragePlanner, {}, False, False),
    "fisher": (FisherPlanner, {}, False, False),
    "coverage, unknown": (CoveragePlanner, UNKNOWN, False, False),
    "coverage, incidence": (CoveragePlanner, {}, False, True),
    "fisher, incidence": (FisherPlanner, {}, False, True),
}
RANK_SUMS = (("unknown 0.5, 20 cm", "coverage"), ("stair unmarked", "coverage"), ("unknown, U_er only", "coverage"))
METRICS = ("f1", "psnr_clean", "f1_5cm", "chamfer")


def scores_on_table(h: Headroom) -> dict[str, np.ndarray]:
    """Every variant's score of the table's spread views (stream 0), and the rank sums."""
    state = table_state(h)  # refused if the seeded mission no longer reaches the table's state
    spread = [r for r in h.rows if r["kind"] == "spread" and int(r.get("stream", 0)) == 0]
    views = np.radians([[r["elevation_deg"], r["azimuth_deg"]] for r in spread])
    scores = {}
    for name, (cls, options, exploration_only, incidence) in VARIANTS.items():
        planner = cls(state.mission.preset.plan, np.random.default_rng(0),
                      UtilityOptions(**{"epsilon": 0.2, **UNMARKED, **options}), exploration_only=exploration_only)
        planner.incidence = incidence
        scores[name] = planner.utility(state.field, views, state.visited, state.targets)
    for a, b in RANK_SUMS:
        scores[f"{a} + {b} (ranks)"] = rankdata(scores[a]) + rankdata(scores[b])
    return scores


def judge(h: Headroom, score: np.ndarray, metric: str) -> tuple[float, float, float]:
    """(Spearman with the gain, share of spread views the top-ranked one beats, Spearman with the streams' mean gain)."""
    gain = h.gains(metric)
    mean_gain = np.array([h.gains(metric, stream=s) for s in range(h.streams)]).mean(axis=0)
    rho, rho_mean = rank_correlation(score, gain), rank_correlation(score, mean_gain)
    return (np.nan if rho is None else rho, float((gain < gain[np.argmax(score)]).mean()),
            np.nan if rho_mean is None else rho_mean)


def summarise(figures: dict) -> None:
    print(f"mean over {len(figures)} tables: rho / spread pick / rho with the streams' mean gain")
    print(f"{'variant':44s}" + "".join(f" | {m:^20s}" for m in METRICS))
    for name in next(iter(figures.values())):
        cells = [np.nanmean([figures[t][name][m] for t in figures], axis=0) for m in METRICS]
        print(f"{name:44s}" + "".join(f" | {c[0]:+.2f} {c[1]:4.0%} {c[2]:+.2f}" for c in cells))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("tables", nargs="+", help="a folder of headroom tables, or some tables' .json files; with "
                        "--summarise, the JSON files earlier runs wrote with --out")
    parser.add_argument("--out", default=None, help="write every table's figures to this JSON file")
    parser.add_argument("--summarise", action="store_true", help="only print the mean table of earlier runs' --out files")
    args = parser.parse_args()
    if args.summarise:
        return summarise({k: v for f in args.tables for k, v in json.loads(Path(f).read_text()).items()})
    paths = [Path(t) for t in args.tables]
    stems = sorted(p.with_suffix("") for p in (paths[0].glob("*.json") if paths[0].is_dir() else paths))
    figures = {}
    for stem in stems:
        h = Headroom.load(stem)
        scores = scores_on_table(h)
        figures[stem.name] = {name: {m: judge(h, s, m) for m in METRICS} for name, s in scores.items()}
        print(f"{stem.name}: F1 rho " + ", ".join(f"{n} {v['f1'][0]:+.2f}" for n, v in figures[stem.name].items()), flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps(figures, indent=1))
    summarise(figures)


if __name__ == "__main__":
    main()
