"""The headroom instrument: does a planner's utility predict what a view will teach?

Introduced in notebook 06. From a seeded STAIR mission's state after K views, N candidate views spread
over the hemisphere (a Fibonacci set) are each added to a copy of the map, which is trained the same way
(the same training state and random stream) and evaluated. A view's realised gain is a metric after it
minus the metric before it (for the chamfer distance, before minus after: a gain is always an
improvement). Every candidate is also scored by three planners' utilities: STAIR's U (Eq. 15),
Exploration's U_er (Eq. 12) and Max View Distance's mean squared camera distance; the three planners' own
picks are realised the same way. The spread of the gains is the headroom a planner has; the rank
correlation (Spearman) of a utility with the gains says whether the utility finds it.
"""
from __future__ import annotations

import copy
import csv
import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from .claims import LOWER_IS_BETTER
from .geometry import Intrinsics, fibonacci_hemisphere, view_to_pose
from .maps import ImplicitMap
from .mission import Mission, MissionConfig, make_output_folder
from .planners import far_enough, make_planner, mean_squared_distance
from .utility import FieldSnapshot, UtilityOptions, score_views

METRICS = ("psnr", "psnr_clean", "f1", "f1_5cm", "chamfer")
UTILITIES = ("stair", "exploration", "max_distance")  # the planners whose utility and pick are measured


@dataclass
class Headroom:
    """What ``measure_headroom`` found: the metrics before the new view, one row per realised view (``kind``:
    "spread" for the spread candidates, else the planner whose pick it is) and, per utility and metric, the
    Spearman rank correlation of the utility with the realised gain over the spread candidates."""

    scene: str
    after: int
    seed: int
    preset: str
    before: dict
    rows: list[dict]
    correlations: dict

    def gains(self, metric: str, kind: str = "spread") -> np.ndarray:
        return np.array([r[f"gain_{metric}"] for r in self.rows if r["kind"] == kind])

    def pick_percentile(self, planner: str, metric: str) -> float:
        """The share of spread candidates whose gain is below that of ``planner``'s pick (1: better than all)."""
        (pick,) = self.gains(metric, planner)
        return float((self.gains(metric) < pick).mean())

    def save(self, folder: str | Path, command: str = "") -> Path:
        """``<scene>_after<K>.csv`` (the rows) and ``.json`` (everything else) in ``folder``; returns the stem."""
        folder = make_output_folder(folder)
        stem = folder / f"{self.scene}_after{self.after}"
        with stem.with_suffix(".csv").open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(self.rows[0]))
            writer.writeheader()
            writer.writerows(self.rows)
        summary = {k: v for k, v in asdict(self).items() if k != "rows"}
        summary["pick_percentiles"] = {p: {m: self.pick_percentile(p, m) for m in METRICS} for p in UTILITIES}
        summary["command"] = command
        stem.with_suffix(".json").write_text(json.dumps(summary, indent=1))
        return stem

    @classmethod
    def load(cls, stem: str | Path) -> "Headroom":
        stem = Path(stem)
        summary = json.loads(stem.with_suffix(".json").read_text())
        with stem.with_suffix(".csv").open() as f:
            rows = [{k: v if k == "kind" else float(v) for k, v in r.items()} for r in csv.DictReader(f)]
        return cls(**{k: summary[k] for k in ("scene", "after", "seed", "preset", "before", "correlations")}, rows=rows)


def gain(metric: str, before: float, after: float) -> float:
    """The improvement of a metric (a reduction for the chamfer distance)."""
    return before - after if metric in LOWER_IS_BETTER else after - before


def measure_headroom(scene: str, after: int, n_candidates: int, seed: int = 0, preset: str = "lite",
                     log=print) -> Headroom:
    """Run a seeded STAIR mission for ``after`` views, then realise ``n_candidates`` spread views and the
    picks of the planners in ``UTILITIES`` as the next view, each on a copy of the map (see the module)."""
    if after < 1 or n_candidates < 2:
        raise ValueError(f"need at least 1 view before and 2 candidates, got after={after}, candidates={n_candidates}")
    mission = Mission(MissionConfig(scene=scene, planner="stair", seed=seed, preset=preset, budget=after))
    mission.run()
    visited, targets = np.array(mission.visited), mission.targets
    before = {m: mission.records[-1][m] for m in METRICS}
    field = mission.map.planning_source
    state = mission.map.state_dict()
    measurements = [mission.simulator.render(view_to_pose(*v)) for v in visited]

    spread = fibonacci_hemisphere(n_candidates, azimuth_offset=np.random.default_rng(seed).uniform(0, 2 * np.pi))
    spread = spread[far_enough(spread, visited)]
    picks = {"stair": mission.planner.next_view(field, visited, targets).view}  # the mission's own next view
    for name in UTILITIES[1:]:
        picks[name] = make_planner(name, mission.preset, seed=seed + 1).next_view(field, visited, targets).view
    views = np.concatenate([spread, np.array([picks[p] for p in UTILITIES])])
    kinds = ["spread"] * len(spread) + list(UTILITIES)

    cfg = mission.preset.plan
    scores = score_views(FieldSnapshot(field), views, targets, Intrinsics.from_fov().scaled(cfg.candidate_scale),
                         cfg.candidate_samples, UtilityOptions(epsilon=cfg.epsilon))
    utilities = {"stair": scores.utility, "exploration": scores.exploration,
                 "max_distance": mean_squared_distance(views, visited)}

    rows = []
    for i, (view, kind) in enumerate(zip(views, kinds)):
        copy_of_map = ImplicitMap.from_preset(mission.preset, seed=seed)
        for m in measurements:
            copy_of_map.add_measurement(m)
        copy_of_map.load_state_dict(copy.deepcopy(state))  # the same training state for every candidate
        copy_of_map.integrate(mission.simulator.render(view_to_pose(*view)))
        result = mission.evaluator.evaluate(copy_of_map)
        rows.append({"kind": kind, "elevation_deg": float(np.degrees(view[0])), "azimuth_deg": float(np.degrees(view[1])),
                     **{f"u_{u}": float(utilities[u][i]) for u in UTILITIES},
                     **{m: float(result[m]) for m in METRICS},
                     **{f"gain_{m}": gain(m, before[m], float(result[m])) for m in METRICS}})
        log(f"{scene} after {after}: view {i + 1}/{len(views)} ({kind}) F1 gain {rows[-1]['gain_f1']:+.3f}, "
            f"clean PSNR gain {rows[-1]['gain_psnr_clean']:+.2f} dB")
    spread_rows = [r for r in rows if r["kind"] == "spread"]
    correlations = {u: {m: rank_correlation([r[f"u_{u}"] for r in spread_rows], [r[f"gain_{m}"] for r in spread_rows])
                        for m in METRICS} for u in UTILITIES}
    return Headroom(scene, after, seed, preset, before, rows, correlations)


def rank_correlation(a, b) -> float | None:
    """Spearman's rank correlation; None when either side does not vary (no ranking to compare)."""
    if np.ptp(a) == 0 or np.ptp(b) == 0:
        return None
    return float(stats.spearmanr(a, b).statistic)
