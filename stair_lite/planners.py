"""Next-best-view planners behind one small interface (paper Sec. III-C and IV-B).

Introduced in notebooks 04 and 05. A planner sees what it reads of the map (``reads``: the trained
SemanticField of the implicit map, the voxel map itself for STE, nothing for the map-free baselines) and
the views visited so far, and returns the next view (elevation, azimuth) with whatever it scored on the
way. Every mission starts from the top view; planners never return a view already visited.

  stair        U = U_et + epsilon U_er, two-stage candidates (N_uni uniform, top K, N_re around each)
  exploration  the same candidates scored by U_er alone
  stair_soft, stair_semantic  beyond the paper (notebook 07): STAIR with the soft target mask, or with the
               semantic-uncertainty term lambda U_sem (``UTILITY_VARIANTS``)
  fixed        a spiral down the hemisphere, no map feedback (the reference code's Fibonacci spiral)
  max_distance the random candidate farthest (mean squared distance) from the visited cameras
  uniform      a random view, area-uniform on the hemisphere
  ste          the explicit baseline's ROI utility on its voxel map (see explicit.py)
  replay       the views of an earlier mission, in order (for the paper's cross-validation)
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .config import PlanConfig, Preset
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
class ROIScores:
    """Per-view scores of the STE planner: its region-of-interest utility (``ExplicitMap.roi_scores``)."""

    ste_utility: np.ndarray

    def columns(self, i: int) -> dict[str, float]:
        """The score of candidate ``i``, named as a mission record's column."""
        return {"ste_utility": float(self.ste_utility[i])}


@dataclass
class Decision:
    """A planner's choice and what it saw: all scored candidates and their scores (if any)."""

    view: np.ndarray
    candidates: np.ndarray | None = None
    scores: Scores | ROIScores | None = None
    chosen_index: int | None = None
    info: dict = field(default_factory=dict)


def far_enough(candidates: np.ndarray, visited: np.ndarray, min_separation: float = MIN_SEPARATION) -> np.ndarray:
    """Which candidates lie more than ``min_separation`` radians from every visited view."""
    if len(visited) == 0:
        return np.ones(len(candidates), dtype=bool)
    return angular_distance(candidates, visited).min(axis=1) > min_separation


class Planner:
    """Interface: ``next_view(source, visited, targets)`` -> Decision, where ``source`` is what the
    planner ``reads`` (the ``planning_source`` of the map of that kind, or None). Its state is its
    random generator (``state_dict``)."""

    name = "planner"
    reads: str | None = None  # the kind of map it plans on ("implicit", "explicit"), or None

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator):
        self.cfg = cfg
        self.rng = rng

    def next_view(self, source, visited: np.ndarray, targets: tuple[int, ...]) -> Decision:
        raise NotImplementedError

    def utility(self, source, views: np.ndarray, visited: np.ndarray, targets: tuple[int, ...]) -> np.ndarray | None:
        """The score the planner ranks ``views`` by (higher: chosen first), or None for a planner that ranks nothing
        (the headroom instrument measures how well this score predicts what a view teaches)."""
        return None

    def state_dict(self) -> dict:
        return {"rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict) -> None:
        self.rng.bit_generator.state = state["rng"]


class UtilityPlanner(Planner):
    """STAIR's two-stage search (paper Sec. III-C): N_uni evenly spread views (a Fibonacci set turned
    by a random azimuth each step), the top K by utility, N_re views resampled around each of them
    at 0.1-0.5 rad, and the best of all; views too close to a visited one are never chosen."""

    reads = "implicit"

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, options: UtilityOptions | None = None,
                 exploration_only: bool = False, exact: bool = False, name: str | None = None):
        super().__init__(cfg, rng)
        self.options = options or UtilityOptions(epsilon=cfg.epsilon)
        self.exploration_only = exploration_only
        self.exact = exact
        self.name = name or ("exploration" if exploration_only else "stair")
        self.intrinsics = Intrinsics.from_fov().scaled(cfg.candidate_scale)

    def _value(self, scores: Scores) -> np.ndarray:
        return scores.exploration if self.exploration_only else scores.utility

    def utility(self, field, views, visited, targets) -> np.ndarray:
        source = field if self.exact else FieldSnapshot(field)
        return self._value(score_views(source, views, targets, self.intrinsics, self.cfg.candidate_samples, self.options))

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
        scores = Scores.concatenate([first, second])
        value = np.where(far_enough(candidates, visited), self._value(scores), -np.inf)
        best = int(np.argmax(value))
        if not np.isfinite(value[best]):
            raise RuntimeError("every candidate lies within the minimum separation of a visited view")
        return Decision(view=candidates[best], candidates=candidates, scores=scores, chosen_index=best)


class FixedPatternPlanner(Planner):
    """A fixed spiral: the reference code's 10-view Fibonacci spiral turned by one random azimuth,
    top-most view dropped, walked from high to low elevation. It never looks at the map."""

    name = "fixed"

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, budget: int):
        super().__init__(cfg, rng)
        spiral = fibonacci_hemisphere(max(budget, 2), azimuth_offset=rng.uniform(0, 2 * np.pi))
        self.sequence = spiral[:-1][::-1]

    def next_view(self, field, visited, targets) -> Decision:
        index = (len(visited) - 1) % len(self.sequence)
        return Decision(view=self.sequence[index], info={"pattern_index": index})


def mean_squared_distance(candidates: np.ndarray, visited: np.ndarray) -> np.ndarray:
    """Max View Distance's score of each candidate view: the mean squared distance [m^2] of its camera to
    the visited cameras."""
    c = view_to_position(candidates[:, 0], candidates[:, 1])
    v = view_to_position(visited[:, 0], visited[:, 1])
    return ((c[:, None, :] - v[None, :, :]) ** 2).sum(-1).mean(axis=1)


class MaxViewDistancePlanner(Planner):
    """The random candidate whose camera has the largest mean squared distance to the visited cameras."""

    name = "max_distance"
    n_candidates = 200

    def utility(self, field, views, visited, targets) -> np.ndarray:
        return mean_squared_distance(views, visited)

    def next_view(self, field, visited, targets) -> Decision:
        candidates = random_hemisphere(self.n_candidates, self.rng)
        distance = mean_squared_distance(candidates, visited)
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
    reads = "explicit"

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, n_candidates: int):
        super().__init__(cfg, rng)
        self.n_candidates = n_candidates

    def utility(self, explicit_map, views, visited, targets) -> np.ndarray:
        return explicit_map.roi_scores(views, targets)

    def next_view(self, explicit_map, visited, targets) -> Decision:
        candidates = random_hemisphere(self.n_candidates, self.rng)
        utility = explicit_map.roi_scores(candidates, targets)
        best = int(np.argmax(np.where(far_enough(candidates, visited), utility, -np.inf)))
        return Decision(view=candidates[best], candidates=candidates, chosen_index=best, scores=ROIScores(utility))


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

    @classmethod
    def from_file(cls, cfg: PlanConfig, rng: np.random.Generator, path: str | Path, budget: int) -> "ReplayPlanner":
        """Follow the views of a mission's ``metrics.json``; it must hold at least ``budget`` of them."""
        try:
            raw = [r["view_rad"] for r in json.loads(Path(path).read_text())["steps"]]
        except FileNotFoundError:
            raise FileNotFoundError(f"replay file not found: {path}") from None
        except (ValueError, UnicodeDecodeError, KeyError, TypeError, IndexError) as err:
            raise ValueError(f"{path} is not a mission's metrics.json (no list of steps with views): "
                             f"{type(err).__name__}: {err}") from None
        for step, view in enumerate(raw, start=1):
            if not (isinstance(view, list) and len(view) == 2 and all(
                    isinstance(a, (int, float)) and not isinstance(a, bool) and np.isfinite(a) for a in view)):
                raise ValueError(f"{path} is not a mission's metrics.json: the view of step {step}, {view!r}, is not "
                                 "an (elevation, azimuth) pair of numbers")
            if not -1e-9 <= view[0] <= np.pi / 2 + 1e-9:  # as view_to_pose accepts
                raise ValueError(f"{path}: the view of step {step} has elevation {view[0]!r} rad, off the hemisphere "
                                 "[0, pi/2]")
        views = np.array(raw, dtype=float).reshape(-1, 2)
        if len(views) < budget:
            raise ValueError(f"{path} holds {len(views)} views, fewer than the budget {budget}")
        return cls(cfg, rng, views)


# The semantic-uncertainty weight lambda of stair_semantic. Measured on lite STAIR missions of scenes 1 and 3
# (steps 2-4, 100 spread candidates, label noise none and high): across the candidates U_sem spreads 0.37-1.0
# times as much as U_er (standard deviations 39-151 against 47-211), so lambda = epsilon gives the semantic
# term about the exploration term's say in the choice, not more.
SEMANTIC_WEIGHT = PlanConfig.epsilon
# Beyond the paper: STAIR's planner with another utility, by name (UtilityOptions beside epsilon).
UTILITY_VARIANTS = {"stair_soft": {"soft_mask": True}, "stair_semantic": {"semantic_weight": SEMANTIC_WEIGHT}}
# The paper's planners that choose views, by name (sweeps build their variants on them, experiments.py),
# the planners beyond the paper, and the replay planner, which follows a recorded mission's views (the
# paper's cross-validation).
PAPER_PLANNERS = {"stair": UtilityPlanner, "exploration": UtilityPlanner, "fixed": FixedPatternPlanner,
                  "max_distance": MaxViewDistancePlanner, "uniform": UniformPlanner, "ste": STEPlanner}
PLANNERS = {**PAPER_PLANNERS, **dict.fromkeys(UTILITY_VARIANTS, UtilityPlanner)}
REPLAY = "replay"


def planner_class(name: str, replay: str | Path | None = None) -> type[Planner]:
    """The class behind a planner name; a clear error for an unknown one, or for a replay file given
    to another planner than ``replay`` (or missing for it)."""
    if name != REPLAY and name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; choose one of {', '.join((*PLANNERS, REPLAY))}")
    if (name == REPLAY) != (replay is not None):
        raise ValueError("planner 'replay' needs a replay file, and a replay file needs planner 'replay'")
    return ReplayPlanner if name == REPLAY else PLANNERS[name]


def make_planner(name: str, preset: Preset, seed: int, replay: str | Path | None = None) -> Planner:
    """Build a planner by name from a preset (its plan config, budget and STE candidate count), with its
    own seeded random generator; ``replay``: the metrics.json whose views the ``replay`` planner follows."""
    cls, cfg, rng = planner_class(name, replay), preset.plan, np.random.default_rng(seed)
    if cls is UtilityPlanner:
        options = UtilityOptions(epsilon=cfg.epsilon, **UTILITY_VARIANTS.get(name, {}))
        return UtilityPlanner(cfg, rng, options, exploration_only=name == "exploration", name=name)
    if cls is FixedPatternPlanner:
        return FixedPatternPlanner(cfg, rng, preset.budget)
    if cls is STEPlanner:
        return STEPlanner(cfg, rng, preset.explicit.n_candidates)
    if cls is ReplayPlanner:
        return ReplayPlanner.from_file(cfg, rng, replay, preset.budget)
    return cls(cfg, rng)
