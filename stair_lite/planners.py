"""Next-best-view planners behind one small interface (paper Sec. III-C and IV-B).

Introduced in notebooks 04 and 05. A planner sees what it reads of the map (``reads``: the trained
SemanticField of the implicit map, the voxel map itself for STE, nothing for the map-free baselines) and
the views visited so far, and returns the next view (elevation, azimuth) with whatever it scored on the
way. Every mission starts from the top view; planners never return a view already visited.

  stair        U = U_et + epsilon U_er, two-stage candidates (N_uni uniform, top K, N_re around each)
  exploration  the same candidates scored by U_er alone
  stair_soft, stair_semantic  beyond the paper (notebook 07): STAIR with the soft target mask, or with the
               semantic-uncertainty term lambda U_sem (registered with those ``UtilityOptions``)
  stair_spread beyond the paper: STAIR whose views keep 35 degrees from every earlier one (not the reference 8.1)
  stair_rings  beyond the paper: STAIR's utility choosing the azimuth only, each view at the fixed spiral's elevation
  fixed        a spiral down the hemisphere, no map feedback (the reference code's Fibonacci spiral)
  max_distance the random candidate farthest (mean squared distance) from the visited cameras
  uniform      a random view, area-uniform on the hemisphere
  ste          the explicit baseline's ROI utility on its voxel map (see explicit.py)
  replay       the views of an earlier mission, in order (for the paper's cross-validation)

Each planner describes itself: what it ``reads``, the record columns of its scores (``score_columns``), how it builds
itself from a preset (``from_preset``) and, where it ranks views, its ``utility``. It is registered once, by name,
below (``register_planner``); a researcher's own planner needs no registration: ``path/to/file.py:ClassName`` names a
subclass of ``Planner`` in its own file (README, "Your own planner").
"""
from __future__ import annotations

import hashlib
import importlib.util
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
from .lattice import CUBE_BOUND
from .utility import FieldSnapshot, Scores, UtilityOptions, poses_in_chunks, render_novel_target_surface, score_views

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


def spiral_after_top(budget: int, azimuth_offset: float = 0.0) -> np.ndarray:
    """The fixed spiral's views after the top one, (budget - 1, 2) [elevation, azimuth]: the rings of a
    ``budget``-view Fibonacci spiral without its top-most, walked from high to low elevation."""
    return fibonacci_hemisphere(max(budget, 2), azimuth_offset=azimuth_offset)[:-1][::-1]


class Planner:
    """Interface: ``next_view(source, visited, targets)`` -> Decision, where ``source`` is what the
    planner ``reads`` (the ``planning_source`` of the map of that kind, or None). Its state is its
    random generator (``state_dict``)."""

    name = "planner"
    reads: str | None = None  # the kind of map it plans on ("implicit", "explicit"), or None
    score_columns: tuple[str, ...] = ()  # the record columns of its ``Decision.scores`` (None where it scores nothing)
    depends_on_budget = False  # its views depend on the mission's budget (a resume may not change the budget)

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator):
        self.cfg = cfg
        self.rng = rng

    @classmethod
    def from_preset(cls, preset: Preset, rng: np.random.Generator, **options) -> "Planner":
        """Build the planner from a preset (its ``plan`` config by default) and its registered options."""
        return cls(preset.plan, rng, **options)

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
    at 0.1-0.5 rad, and the best of all; views within ``min_separation`` of a visited one are never chosen."""

    reads = "implicit"
    score_columns = ("utility", "exploitation", "exploration", "semantic_uncertainty")

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, options: UtilityOptions | None = None,
                 exploration_only: bool = False, exact: bool = False, name: str | None = None,
                 min_separation: float = MIN_SEPARATION):
        super().__init__(cfg, rng)
        self.options = options or UtilityOptions.from_plan(cfg)
        self.exploration_only = exploration_only
        self.min_separation = min_separation  # [rad] from every visited view (the reference code's 8.1 degrees)
        self.exact = exact
        self.name = name or ("exploration" if exploration_only else "stair")
        self.intrinsics = Intrinsics.from_fov().scaled(cfg.candidate_scale)

    @classmethod
    def from_preset(cls, preset, rng, exploration_only: bool = False, min_separation: float = MIN_SEPARATION,
                    **utility_options) -> "UtilityPlanner":
        """The preset's candidates, epsilon and marking of the unknown; ``utility_options``: ``UtilityOptions`` beside
        (or instead of) those."""
        return cls(preset.plan, rng, UtilityOptions.from_plan(preset.plan, **utility_options),
                   exploration_only=exploration_only, min_separation=min_separation)

    def _source(self, field, targets):
        """What the candidates are rendered from: the field itself (``exact``) or its snapshot."""
        return field if self.exact else FieldSnapshot.for_planning(field, self.options, targets)

    def _score(self, source, views: np.ndarray, targets):
        """The scores of ``views`` (a ``Scores``: Eqs. 12-15)."""
        return score_views(source, views, targets, self.intrinsics, self.cfg.candidate_samples, self.options)

    def _value(self, scores: Scores) -> np.ndarray:
        return scores.exploration if self.exploration_only else scores.utility

    def utility(self, field, views, visited, targets) -> np.ndarray:
        return self._value(self._score(self._source(field, targets), views, targets))

    def _crowded(self, visited) -> RuntimeError:
        return RuntimeError(f"every candidate lies within {np.degrees(self.min_separation):.1f} degrees (the minimum "
                            f"separation) of one of the {len(visited)} visited views")

    def _best_allowed(self, candidates: np.ndarray, scores, visited: np.ndarray) -> int:
        """The index of the candidate of highest value among those ``min_separation`` from every visited view."""
        value = np.where(far_enough(candidates, visited, self.min_separation), self._value(scores), -np.inf)
        best = int(np.argmax(value))
        if not np.isfinite(value[best]):
            raise self._crowded(visited)
        return best

    def next_view(self, field, visited, targets) -> Decision:
        cfg = self.cfg
        source = self._source(field, targets)
        uniform = fibonacci_hemisphere(cfg.n_uniform, azimuth_offset=self.rng.uniform(0, 2 * np.pi))
        allowed = far_enough(uniform, visited, self.min_separation)
        if not allowed.any():  # the second stage draws only around allowed views
            raise self._crowded(visited)
        first = self._score(source, uniform, targets)
        order = [i for i in np.argsort(-self._value(first), kind="stable") if allowed[i]][: cfg.top_k]
        resampled = np.concatenate(
            [local_views(uniform[i], cfg.n_resample, self.rng, *cfg.resample_angle) for i in order]
        ) if cfg.n_resample > 0 and order else np.zeros((0, 2))
        candidates = np.concatenate([uniform, resampled])
        scores = type(first).concatenate([first] + ([self._score(source, resampled, targets)] if len(resampled) else []))
        best = self._best_allowed(candidates, scores, visited)
        # the first-stage views the second stage was drawn around, best first (the order of the draws)
        return Decision(view=candidates[best], candidates=candidates, scores=scores, chosen_index=best,
                        info={"resampled_around": uniform[order]})


class RingPlanner(UtilityPlanner):
    """Beyond the paper: STAIR's utility choosing where around the scene to look, at the fixed spiral's elevations.
    The n-th view after the top one lies on the spiral's n-th ring (``spiral_after_top``); of as many views evenly
    spread in azimuth on that ring as STAIR scores in its two stages (N_uni + K N_re), the one of highest utility.
    Set beside the spiral and STAIR, it separates what STAIR's views lack: the spiral's spread of elevations, or its
    choice of azimuths (RESULTS.md, "The spiral's elevations, STAIR's azimuths")."""

    depends_on_budget = True

    @classmethod
    def from_preset(cls, preset, rng, **utility_options) -> "RingPlanner":
        return cls(preset.plan, rng, UtilityOptions.from_plan(preset.plan, **utility_options), budget=preset.budget)

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, options: UtilityOptions | None = None,
                 budget: int = 10, **kwargs):
        super().__init__(cfg, rng, options, **kwargs)
        self.elevations = spiral_after_top(budget)[:, 0]

    def next_view(self, field, visited, targets) -> Decision:
        elevation = self.elevations[(len(visited) - 1) % len(self.elevations)]
        n = self.cfg.n_uniform + self.cfg.top_k * self.cfg.n_resample
        azimuths = (self.rng.uniform(0, 2 * np.pi) + 2 * np.pi * np.arange(n) / n) % (2 * np.pi)
        candidates = np.stack([np.full(n, elevation), azimuths], axis=1)
        scores = self._score(self._source(field, targets), candidates, targets)
        best = self._best_allowed(candidates, scores, visited)
        return Decision(view=candidates[best], candidates=candidates, scores=scores, chosen_index=best,
                        info={"ring_elevation": float(elevation)})


@dataclass
class NoveltyScores:
    """Per-view scores of a novelty utility (``CoveragePlanner``, ``FisherPlanner``), under its record column."""

    column: str
    values: np.ndarray

    @classmethod
    def concatenate(cls, parts: list["NoveltyScores"]) -> "NoveltyScores":
        return cls(parts[0].column, np.concatenate([p.values for p in parts]))

    def columns(self, i: int) -> dict[str, float]:
        return {self.column: float(self.values[i])}


class CoveragePlanner(UtilityPlanner):
    """Beyond the paper: a visibility-count utility. A view scores the target surface its rays would see (the
    rendering weight w_i of each sample times its target probability p_T), each surface vertex weighted by how rarely
    the measurements have seen it: nu(x) = 1 / (1 + views that saw a surface at x). The unknown is marked as the
    options say (``UtilityOptions.unknown_occupancy``, ``unknown_target_radius``), so unseen target surface counts
    fully. The same two-stage search as STAIR's."""

    score_columns = ("coverage",)
    power = 1  # the rendering weight's exponent
    incidence = False  # weigh each surface sample by |cos| of the angle between the ray and the surface normal

    def _novelty(self, field):
        return 1.0 / (1.0 + field.surface_views)

    def _source(self, field, targets):
        return FieldSnapshot.for_planning(field, self.options, targets, novelty=self._novelty(field), normals=self.incidence)

    def _score(self, source, views, targets) -> NoveltyScores:
        n = self.cfg.candidate_samples
        values = [render_novel_target_surface(source, self.intrinsics, poses, n, targets, self.power).sum(dim=(1, 2)).cpu().numpy()
                  for poses in poses_in_chunks(views, self.intrinsics, n)]
        return NoveltyScores(self.score_columns[0], np.concatenate(values) if values else np.zeros(0))

    def _value(self, scores: NoveltyScores) -> np.ndarray:
        return scores.values


class FisherPlanner(CoveragePlanner):
    """Beyond the paper: a Fisher-information utility (FisherRF's idea on this map). Take each lattice vertex's surface
    as a parameter whose information grows with the rays that measured it: I(x) = rays whose surface point lies
    nearest x. A candidate ray adds w_i^2 at its samples (the squared sensitivity of the rendered depth to the surface
    there), so with the diagonal approximation the view's information gain is trace(I_new I^-1) =
    sum_rays sum_i w_i^2 p_T(x_i) / (I(x_i) + 1) (the 1: one ray's worth of prior information)."""

    score_columns = ("fisher",)
    power = 2

    def _novelty(self, field):
        return 1.0 / (1.0 + field.surface_rays)


class FixedPatternPlanner(Planner):
    """A fixed spiral: the reference code's 10-view Fibonacci spiral turned by one random azimuth,
    top-most view dropped, walked from high to low elevation. It never looks at the map."""

    name = "fixed"
    depends_on_budget = True

    @classmethod
    def from_preset(cls, preset, rng) -> "FixedPatternPlanner":
        return cls(preset.plan, rng, preset.budget)

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, budget: int):
        super().__init__(cfg, rng)
        self.sequence = spiral_after_top(budget, azimuth_offset=rng.uniform(0, 2 * np.pi))

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

    def __init__(self, cfg: PlanConfig, rng: np.random.Generator, n_candidates: int = 200):
        super().__init__(cfg, rng)
        self.n_candidates = n_candidates  # random candidates per step

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
    score_columns = ("ste_utility",)

    @classmethod
    def from_preset(cls, preset, rng) -> "STEPlanner":
        return cls(preset.plan, rng, preset.explicit.n_candidates)  # its knobs live in the explicit map's config

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
    def from_preset(cls, preset, rng, replay: str | Path | None = None) -> "ReplayPlanner":
        return cls.from_file(preset.plan, rng, replay, preset.budget)

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
# times as much as U_er (standard deviations 39-151 against 47-211), so lambda = 0.2, the paper's epsilon, gives the
# semantic term about the exploration term's say in the choice, not more.
SEMANTIC_WEIGHT = 0.2


@dataclass(frozen=True)
class Registered:
    """A planner by name: its class, the options its ``from_preset`` takes, and whether it is one of the paper's."""

    cls: type[Planner]
    options: dict
    paper: bool


PLANNERS: dict[str, Registered] = {}
REPLAY = "replay"


def register_planner(name: str, cls: type[Planner], paper: bool = False, **options) -> None:
    """Make a planner available by name to missions, sweeps, the headroom instrument and the command line:
    ``cls.from_preset(preset, rng, **options)`` builds it."""
    if name in PLANNERS or name == REPLAY or ":" in name or "/" in name:
        raise ValueError(f"the planner name {name!r} is taken or not a plain name")
    PLANNERS[name] = Registered(cls, options, paper)


def paper_planners() -> tuple[str, ...]:
    """The paper's planners that choose views (a sweep's "base" variants)."""
    return tuple(name for name, r in PLANNERS.items() if r.paper)


register_planner("stair", UtilityPlanner, paper=True)
register_planner("exploration", UtilityPlanner, paper=True, exploration_only=True)
register_planner("fixed", FixedPatternPlanner, paper=True)
register_planner("max_distance", MaxViewDistancePlanner, paper=True)
register_planner("uniform", UniformPlanner, paper=True)
register_planner("ste", STEPlanner, paper=True)
# beyond the paper (notebook 07): STAIR's planner with the soft target mask, or with the semantic-uncertainty term
register_planner("stair_soft", UtilityPlanner, soft_mask=True)
register_planner("stair_semantic", UtilityPlanner, semantic_weight=SEMANTIC_WEIGHT)
# the authors' code's rule (README, "The league"): samples below o = 0.01 or of the background class deleted, the ray's
# uncertainty 1 - exp(-H_ray) (bits), only on rays of accumulated opacity above 0.01, and no marking of the unknown
register_planner("stair_reference", UtilityPlanner, delete_background=True, min_occupancy=0.01, saturating_rays=True,
                 min_ray_opacity=0.01, unknown_occupancy=0.0, unknown_target_radius=0.0)
# the headroom league (README): STAIR whose planning renders leave the unknown unmarked (the rule before the league:
# unknown space carries no entropy) and STAIR with the shipped presets' marking whatever a preset says (at paper, lite
# and smoke it is stair itself); a visibility-count and a Fisher-information utility, which look through unknown space
# at the surfaces behind it (the league measured them best so)
register_planner("stair_unmarked", UtilityPlanner, unknown_occupancy=0.0, unknown_target_radius=0.0)
register_planner("stair_unknown", UtilityPlanner, unknown_occupancy=PlanConfig.unknown_occupancy,
                 unknown_target_radius=PlanConfig.unknown_target_radius)
# STAIR whose planning renders mark the unknown only in the ball inscribed in the scene cube, the volume a mission must
# reconstruct (every shipped scene's objects lie within 1.44 m of its centre): the cube's corners reach out among the
# cameras (RESULTS, "A lead"), and the ball is the same from every azimuth
register_planner("stair_volume", UtilityPlanner, unknown_occupancy=PlanConfig.unknown_occupancy,
                 unknown_target_radius=PlanConfig.unknown_target_radius, unknown_within=CUBE_BOUND)
# STAIR whose views keep at least 35 degrees from every earlier one (the reference code's rule keeps 8.1): the same
# utility and marking, only the spread of a mission's views forced (RESULTS, "A lead": at the paper scale STAIR's new
# view lies a median 19 degrees from its nearest earlier one, the spiral's 43). With 100 first-stage candidates 35
# degrees leave at least 8 of them allowed at every step of a ten-view mission even when each pick is the allowed view
# nearest the earlier ones (200 simulated missions; 40 degrees left none in one)
register_planner("stair_spread", UtilityPlanner, min_separation=float(np.radians(35.0)))
# STAIR's utility choosing only the azimuth, each view on the fixed spiral's ring for its step (RESULTS, "The spiral's
# elevations, STAIR's azimuths"): the spiral's spread of elevations with STAIR's choice of where to look
register_planner("stair_rings", RingPlanner)
register_planner("coverage", CoveragePlanner, unknown_occupancy=0.0, unknown_target_radius=0.0)
register_planner("fisher", FisherPlanner, unknown_occupancy=0.0, unknown_target_radius=0.0)


def planner_file_hash(name: str) -> str | None:
    """sha256 of the file of a planner given as ``path/to/file.py:ClassName`` (None for a registered name)."""
    if not is_planner_file(name):
        return None
    return hashlib.sha256(_planner_path(name).read_bytes()).hexdigest()


def is_planner_file(name: str) -> bool:
    """Whether a planner name is ``path/to/file.py:ClassName``: a researcher's own planner in its own file."""
    path, _, cls = name.rpartition(":")
    return path.endswith(".py") and cls.isidentifier()


def _planner_path(name: str) -> Path:
    path = Path(name.rpartition(":")[0])
    if not path.is_file():
        raise ValueError(f"planner {name!r}: the file {path} does not exist (or is not a regular file)")
    return path


def _class_from_file(name: str) -> type[Planner]:
    """The class ``ClassName`` of ``path/to/file.py:ClassName``, loaded from the file; it must subclass Planner."""
    path, cls_name = _planner_path(name), name.rpartition(":")[2]
    module_name = f"stair_lite_user_planner_{hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:12]}"
    spec = importlib.util.spec_from_file_location(module_name, path)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as err:
        raise ValueError(f"planner {name!r}: loading {path} failed ({type(err).__name__}: {err})") from None
    cls = getattr(module, cls_name, None)
    if not (isinstance(cls, type) and issubclass(cls, Planner)):
        raise ValueError(f"planner {name!r}: {path} defines no subclass of stair_lite.planners.Planner named {cls_name}")
    return cls


def planner_class(name: str, replay: str | Path | None = None) -> type[Planner]:
    """The class behind a planner name (or ``path/to/file.py:ClassName``); a clear error for an unknown one, or for a
    replay file given to another planner than ``replay`` (or missing for it)."""
    if (name == REPLAY) != (replay is not None):
        raise ValueError("planner 'replay' needs a replay file, and a replay file needs planner 'replay'")
    if name == REPLAY:
        return ReplayPlanner
    if is_planner_file(name):
        return _class_from_file(name)
    if name not in PLANNERS:
        raise ValueError(f"unknown planner {name!r}; choose one of {', '.join((*PLANNERS, REPLAY))}, or give "
                         "path/to/file.py:ClassName")
    return PLANNERS[name].cls


def make_planner(name: str, preset: Preset, seed: int, replay: str | Path | None = None) -> Planner:
    """Build a planner by name (or ``path/to/file.py:ClassName``) from a preset, with its own seeded random generator;
    ``replay``: the metrics.json whose views the ``replay`` planner follows."""
    cls, rng = planner_class(name, replay), np.random.default_rng(seed)
    options = PLANNERS[name].options if name in PLANNERS else {"replay": replay} if name == REPLAY else {}
    planner = cls.from_preset(preset, rng, **options)
    planner.name = name
    return planner
