"""Next-best-view planners behind one small interface (paper Sec. III-C and IV-B).

Introduced in notebooks 04 and 05. A planner sees the map (a trained SemanticField) and the views
visited so far and returns the next view (elevation, azimuth) with whatever it scored on the way.
Every mission starts from the top view; planners never return a view already visited.

  stair        U = U_et + epsilon U_er, two-stage candidates (N_uni uniform, top K, N_re around each)
  exploration  the same candidates scored by U_er alone
  fixed        a spiral down the hemisphere, no map feedback (the reference code's Fibonacci spiral)
  max_distance the random candidate farthest (mean squared distance) from the visited cameras
  uniform      a random view, area-uniform on the hemisphere
  ste          the explicit baseline's ROI utility on its voxel map (see explicit.py)
  replay       the views of an earlier mission, in order (for the paper's cross-validation)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .config import PlanConfig
from .geometry import (
    Intrinsics,
    angular_distance,
    fibonacci_hemisphere,
    local_views,
    random_hemisphere,
    view_to_position,
)
from .utility import FieldSnapshot, Scores, UtilityOptions, score_views

# The reference code rejects candidates within cosine distance 0.01 (about 8.1 degrees) of a visited view.
MIN_SEPARATION = float(np.arccos(1.0 - 0.01))


@dataclass
class Decision:
    """A planner's choice and what it saw: all scored candidates and their scores (if any)."""

    view: np.ndarray
    candidates: np.ndarray | None = None
    scores: Scores | None = None
    chosen_index: int | None = None
    info: dict = field(default_factory=dict)


def far_enough(candidates: np.ndarray, visited: np.ndarray, min_separation: float = MIN_SEPARATION) -> np.ndarray:
    """Which candidates lie more than ``min_separation`` radians from every visited view."""
    if len(visited) == 0:
        return np.ones(len(candidates), dtype=bool)
    return angular_distance(candidates, visited).min(axis=1) > min_separation


class Planner:
    """Interface: ``next_view(field, visited, targets)`` -> Decision. ``needs_field`` tells the mission
    whether planning reads the map (so a snapshot is worth computing)."""

    name = "planner"
    needs_field = False

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator):
        self.cfg = cfg
        self.rng = rng

    def next_view(self, field, visited: np.ndarray, targets: tuple[int, ...]) -> Decision:
        raise NotImplementedError


class UtilityPlanner(Planner):
    """STAIR's two-stage search (paper Sec. III-C): N_uni evenly spread views (a Fibonacci set turned
    by a random azimuth each step), the top K by utility, N_re views resampled around each of them
    at 0.1-0.5 rad, and the best of all; views too close to a visited one are never chosen."""

    needs_field = True

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, options: UtilityOptions, exploration_only: bool = False,
                 exact: bool = False):
        super().__init__(cfg, rng)
        self.options = options
        self.exploration_only = exploration_only
        self.exact = exact
        self.name = "exploration" if exploration_only else "stair"
        self.intrinsics = Intrinsics.from_fov().scaled(cfg.candidate_scale)

    def _value(self, scores: Scores) -> np.ndarray:
        return scores.exploration if self.exploration_only else scores.utility

    def next_view(self, field, visited, targets) -> Decision:
        cfg = self.cfg
        source = field if self.exact else FieldSnapshot(field)
        uniform = fibonacci_hemisphere(cfg.n_uniform, azimuth_offset=self.rng.uniform(0, 2 * np.pi))
        first = score_views(source, uniform, targets, self.intrinsics, cfg.candidate_samples, self.options)
        allowed = far_enough(uniform, visited)
        order = [i for i in np.argsort(-self._value(first), kind="stable") if allowed[i]][: cfg.top_k]
        resampled = np.concatenate(
            [local_views(uniform[i], cfg.n_resample, self.rng, *cfg.resample_angle) for i in order]
        ) if cfg.n_resample > 0 and order else np.zeros((0, 2))
        second = score_views(source, resampled, targets, self.intrinsics, cfg.candidate_samples, self.options)
        candidates = np.concatenate([uniform, resampled])
        scores = Scores(*(np.concatenate([getattr(first, k), getattr(second, k)]) for k in ("exploration", "exploitation", "utility")))
        value = np.where(far_enough(candidates, visited), self._value(scores), -np.inf)
        best = int(np.argmax(value))
        if not np.isfinite(value[best]):
            raise RuntimeError("every candidate lies within the minimum separation of a visited view")
        return Decision(view=candidates[best], candidates=candidates, scores=scores, chosen_index=best)


class FixedPatternPlanner(Planner):
    """A fixed spiral: the reference code's 10-view Fibonacci spiral turned by one random azimuth,
    top-most view dropped, walked from high to low elevation. It never looks at the map."""

    name = "fixed"

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, budget: int = 10):
        super().__init__(cfg, rng)
        spiral = fibonacci_hemisphere(max(budget, 2), azimuth_offset=rng.uniform(0, 2 * np.pi))
        self.sequence = spiral[:-1][::-1]

    def next_view(self, field, visited, targets) -> Decision:
        index = (len(visited) - 1) % len(self.sequence)
        return Decision(view=self.sequence[index], info={"pattern_index": index})


class MaxViewDistancePlanner(Planner):
    """The random candidate whose camera has the largest mean squared distance to the visited cameras."""

    name = "max_distance"
    n_candidates = 200

    def next_view(self, field, visited, targets) -> Decision:
        candidates = random_hemisphere(self.n_candidates, self.rng)
        c = view_to_position(candidates[:, 0], candidates[:, 1])
        v = view_to_position(visited[:, 0], visited[:, 1])
        distance = ((c[:, None, :] - v[None, :, :]) ** 2).sum(-1).mean(axis=1)
        best = int(np.argmax(np.where(far_enough(candidates, visited), distance, -np.inf)))
        return Decision(view=candidates[best], candidates=candidates, chosen_index=best, info={"mean_sq_distance": float(distance[best])})


class UniformPlanner(Planner):
    """A random view, area-uniform on the hemisphere."""

    name = "uniform"

    def next_view(self, field, visited, targets) -> Decision:
        while True:
            view = random_hemisphere(1, self.rng)
            if far_enough(view, visited)[0]:
                return Decision(view=view[0])


class STEPlanner(Planner):
    """The explicit baseline: the random candidate with the highest ROI utility on the voxel map
    (``ExplicitMap.roi_scores``); area-uniform candidates (the reference code's cube-normalised
    sampling is biased) and, like the others, never within 8.1 degrees of a visited view."""

    name = "ste"
    needs_field = True

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, n_candidates: int = 100):
        super().__init__(cfg, rng)
        self.n_candidates = n_candidates

    def next_view(self, explicit_map, visited, targets) -> Decision:
        candidates = random_hemisphere(self.n_candidates, self.rng)
        utility = explicit_map.roi_scores(candidates, targets)
        best = int(np.argmax(np.where(far_enough(candidates, visited), utility, -np.inf)))
        return Decision(view=candidates[best], candidates=candidates, chosen_index=best,
                        scores=Scores(exploration=utility, exploitation=utility, utility=utility))


class ReplayPlanner(Planner):
    """Follows the views of a recorded mission, in order (no map feedback)."""

    name = "replay"

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, views: np.ndarray):
        super().__init__(cfg, rng)
        self.views = np.asarray(views, dtype=float)

    def next_view(self, field, visited, targets) -> Decision:
        if len(visited) >= len(self.views):
            raise ValueError(f"the replayed mission has only {len(self.views)} views")
        return Decision(view=self.views[len(visited)])


PLANNERS = ("stair", "exploration", "fixed", "max_distance", "uniform", "ste")


def make_planner(name: str, cfg: PlanConfig, seed: int, epsilon: float | None = None, budget: int = 10,
                 options: UtilityOptions | None = None, n_ste_candidates: int = 100) -> Planner:
    """Build a planner by name, with its own seeded random generator."""
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; choose one of {', '.join(PLANNERS)}")
    rng = np.random.default_rng(seed)
    if name == "ste":
        return STEPlanner(cfg, rng, n_ste_candidates)
    options = options or UtilityOptions(epsilon=cfg.epsilon if epsilon is None else epsilon)
    if name == "stair":
        return UtilityPlanner(cfg, rng, options)
    if name == "exploration":
        return UtilityPlanner(cfg, rng, options, exploration_only=True)
    if name == "fixed":
        return FixedPatternPlanner(cfg, rng, budget)
    if name == "max_distance":
        return MaxViewDistancePlanner(cfg, rng)
    return UniformPlanner(cfg, rng)
