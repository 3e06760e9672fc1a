"""Configuration: plain frozen dataclasses and the named presets ``paper``, ``lite`` and ``smoke``.

``paper`` carries the paper's numbers (Sec. IV-A). ``lite`` is the CPU default; its sizes were chosen
by measurement (see ``benchmarks/`` and the README), trading grid resolution and rays per batch for speed.
"""
from __future__ import annotations

import numbers
from dataclasses import dataclass, replace
from dataclasses import field as dataclass_field

from .lattice import CUBE_BOUND


SEED_LIMIT = 2**32  # seeds are whole numbers from 0 to SEED_LIMIT - 1 (numpy's and torch's seeds)
MAX_BUDGET = 50  # measurements: the 8.1 deg caps around 49 visited views cover at most half the hemisphere
# The largest exploration weight: the utility is summed in float32, whose 24-bit mantissa resolves 6e-8 of a
# value, and U_et <= U_er, so beyond about 1e7 the exploitation term no longer changes any choice (the planner is
# Exploration's), and near 3.4e38 epsilon U_er overflows to inf.
MAX_EPSILON = 1e6


def check_epsilon(epsilon: float) -> None:
    """The exploration weight of Eq. 15 is a number from 0 to ``MAX_EPSILON``."""
    if isinstance(epsilon, bool) or not (isinstance(epsilon, numbers.Real) and 0 <= epsilon <= MAX_EPSILON):
        raise ValueError(f"epsilon must be a number from 0 to {MAX_EPSILON:g}, got {epsilon!r}")


def check_budget(budget: int) -> None:
    """A mission makes at least one measurement (the top view) and at most ``MAX_BUDGET``: every planner keeps its
    views 8.1 deg apart, and a cap of that radius around each of 49 views covers at most half the hemisphere
    (2 pi (1 - cos 8.1 deg) = 0.063 of its 2 pi each), so a next view can always be found."""
    if isinstance(budget, bool) or not isinstance(budget, numbers.Integral) or not 1 <= budget <= MAX_BUDGET:
        raise ValueError(f"budget must be a whole number of measurements from 1 to {MAX_BUDGET}, got {budget!r}")


@dataclass(frozen=True)
class FieldConfig:
    """The map: three dense feature grids and small MLPs (paper Sec. III-A)."""

    grid_resolution: int = 128
    occ_channels: int = 3  # T_occ
    rgb_channels: int = 6  # T_rgb
    sem_channels: int = 7  # T_sem = number of classes (identity semantic head)
    pe_frequencies: int = 3  # gamma(x) = [x, sin(2^k x), cos(2^k x)], k < 3: R^3 -> R^21
    # The occupancy head: one linear layer on (f_occ, sin/cos of gamma), as the reference code; the paper's text
    # states two hidden layers of 32 and the raw x in gamma, which invent volume under the ground (README)
    occ_hidden: tuple[int, ...] = ()
    # the occupancy head reads gamma's sin/cos terms beside f_occ (the reference code). They fill volume no ray reached
    # below the ground, and without them lite's surfaces do not become opaque (RESULTS.md, "The four measurements", 3)
    occ_reads_position: bool = True
    # occupancy only where a measurement reached: a point's occupancy is the head's times the trilinear share of its
    # cell's corners that a measured ray passed in front of its surface (or hit); a cell no ray reached is empty
    # (README, "No phantom"). Off: the head everywhere, as the paper and the reference code
    reached_only: bool = True
    rgb_hidden: tuple[int, ...] = (128, 128)
    occupancy_shift: float = -6.0  # o = 1 - exp(-softplus(f + shift)): the map starts almost empty
    bound: float = CUBE_BOUND  # the grids span the scene cube [-bound, bound]^3


@dataclass(frozen=True)
class RenderConfig:
    """Samples along rays (paper Sec. III-B) for training, evaluation and candidate views."""

    near: float = 0.2
    n_samples: int = 200  # uniform samples inside the scene cube, per ray
    n_surface_samples: int = 0  # extra training samples around the measured depth (lite speed-up)
    surface_band: float = 0.08  # half-width [m] of the band those samples are drawn from
    # training rays that hit a surface end this far [m] behind their measured depth (None: at the cube's far side).
    # Beyond it a measurement says nothing; samples there let the losses fill the unseen volume behind every
    # surface, which is how the map invented volume under the ground (README, "No phantom")
    behind_surface: float | None = 0.03
    # rays rendered together outside training (evaluation, meshes' test views): at 200 samples a ray, the colour
    # MLP's activations of 2048 rays stay under 0.5 GB (8192 took a paper-preset evaluation to 3.2 GB)
    chunk_rays: int = 2048
    # colour and class probabilities are evaluated only where the occupancy exceeds this (the reference
    # code's 0.01, which the paper does not state; lite keeps 0: every sample whose weight matters)
    colour_min_occupancy: float = 0.01


@dataclass(frozen=True)
class TrainConfig:
    """Incremental training (paper Sec. III-B): loss weights, batch split, iterations per view."""

    lambda_rgb: float = 1.0
    lambda_depth: float = 0.1
    lambda_sem: float = 1.0
    rays_new: int = 4000
    rays_replay: int = 4000
    iterations_per_view: int = 200
    lr_grid: float = 0.05
    lr_mlp: float = 0.02
    # the occupancy head's learning rate (None: lr_mlp, as the reference code). A linear head at 0.02 needs about
    # 200 iterations to make a view's surfaces opaque; lite trains 80 per view and gives it 0.05 (README, "No phantom")
    lr_occupancy_head: float | None = None
    # empty-space skipping in training: samples in lattice cells where the field's occupancy was below this when
    # the skip grid was last built (every ``skip_refresh`` iterations of an update, and at its start), and where
    # no measured surface lies, are not evaluated (None: evaluate every sample)
    skip_below: float | None = 1e-3
    skip_refresh: int = 50  # (lite: 20, for its 80 iterations per view)
    # rays rendered per forward/backward pass; a larger batch accumulates its gradient over several passes
    # (the same gradient, less memory: the paper preset's 8000 rays x 200 samples in 5 passes peak at 1.8 GB,
    # in 2 passes at 2.8 GB; benchmarks/bench_paper_cpu.py)
    rays_per_pass: int = 1600


@dataclass(frozen=True)
class EvalConfig:
    """Evaluation (paper Sec. IV-A): test views, image size, mesh resolution, points per mesh, threshold."""

    n_test_views: int = 100
    image_scale: float = 1.0  # test images at this fraction of the 400x400 measurements
    mesh_resolution: int = 256
    mesh_points: int = 1_000_000
    f1_threshold: float = 0.01  # 1 cm
    more_f1_thresholds: tuple[float, ...] = (0.02, 0.05)  # F1 also at 2 and 5 cm: it resolves coarse maps
    # samples per ray of the field's evaluation renders (the paper's 200). With occupancy only where a ray reached, a
    # surface is a shell about one lattice cell thick; samples further apart than a cell step over it and the render
    # comes out too transparent (README, "No phantom")
    render_samples: int = 200


@dataclass(frozen=True)
class PlanConfig:
    """Candidate views and utility (paper Sec. III-C and IV-A)."""

    n_uniform: int = 100  # N_uni
    top_k: int = 10  # K
    n_resample: int = 10  # N_re
    resample_angle: tuple[float, float] = (0.1, 0.5)  # radians, as the reference code
    candidate_scale: float = 0.2  # 400x400 -> 80x80 = N_ray
    candidate_samples: int = 200  # N_pt
    epsilon: float = 0.2  # the exploration weight of Eq. 15 (the one default; UtilityOptions takes it from here)
    # how the planning renders mark space no measured ray reached (utility.UtilityOptions; the field itself keeps it
    # empty, so metrics and meshes never see it): its prior occupancy (0.5, the most uncertain: the paper's intent that
    # uncertainty marks what is unexplored, Sec. III-C; 0 would give unknown space no entropy, as the authors' code in
    # effect), and the distance [m] from a target surface within which it renders as that target. The headroom league
    # chose these (README, "The league of utilities")
    unknown_occupancy: float = 0.5
    unknown_target_radius: float = 0.2

    def __post_init__(self):
        check_epsilon(self.epsilon)


@dataclass(frozen=True)
class ExplicitConfig:
    """The explicit STE baseline's map (OctoMap's sensor model and clamping) and ROI planner."""

    resolution: int = 128  # the field's grid: the paper compares both maps at one grid size (Sec. IV-C; Preset checks)
    bound: float = CUBE_BOUND
    prob_hit: float = 0.7
    prob_miss: float = 0.4
    clamp_min: float = 0.12
    clamp_max: float = 0.97
    carve_background: bool = True  # rays that hit nothing inside the cube mark their whole path free
    pixel_stride: int = 2  # integrate every n-th pixel in each direction
    n_candidates: int = 100  # random candidate views per planning step
    candidate_scale: float = 0.1  # 400x400 -> 40x40 rays per candidate, as the reference code
    roi_max_distance: int = 10  # voxels: unknown voxels closer than this to a target voxel score higher


@dataclass(frozen=True)
class Preset:
    """Everything a mission needs, under one name."""

    name: str
    field: FieldConfig = dataclass_field(default_factory=FieldConfig)
    render: RenderConfig = dataclass_field(default_factory=RenderConfig)
    train: TrainConfig = dataclass_field(default_factory=TrainConfig)
    eval: EvalConfig = dataclass_field(default_factory=EvalConfig)
    plan: PlanConfig = dataclass_field(default_factory=PlanConfig)
    explicit: ExplicitConfig = dataclass_field(default_factory=ExplicitConfig)
    budget: int = 10  # measurements per mission, the top view included (the default of missions and sweeps)

    def __post_init__(self):
        check_budget(self.budget)
        if self.explicit.resolution != self.field.grid_resolution:
            raise ValueError(f"preset {self.name!r}: the voxel map's grid ({self.explicit.resolution}^3) must equal the "
                             f"field's ({self.field.grid_resolution}^3): the paper compares both maps at one grid size "
                             "(Sec. IV-C)")

    def with_epsilon(self, epsilon: float) -> "Preset":
        """This preset with another exploration weight (Eq. 15)."""
        return replace(self, plan=replace(self.plan, epsilon=epsilon))

    def with_budget(self, budget: int) -> "Preset":
        """This preset with another number of measurements per mission."""
        return replace(self, budget=budget)


PAPER = Preset(name="paper")

LITE = Preset(
    name="lite",
    field=FieldConfig(grid_resolution=64, rgb_hidden=(32, 32)),
    render=RenderConfig(n_samples=48, n_surface_samples=16, chunk_rays=4096, colour_min_occupancy=0.0),
    train=TrainConfig(rays_new=512, rays_replay=512, iterations_per_view=80, skip_refresh=20, lr_occupancy_head=0.05),
    eval=EvalConfig(n_test_views=20, image_scale=0.25, mesh_resolution=128, mesh_points=100_000),
    plan=PlanConfig(candidate_scale=0.1, candidate_samples=64),
    explicit=ExplicitConfig(resolution=64),  # the field's grid
)

# A seconds-long preset for smoke tests of whole pipelines (missions, sweeps); its metrics mean little.
SMOKE = Preset(
    name="smoke",
    field=FieldConfig(grid_resolution=24, rgb_hidden=(16,)),
    render=RenderConfig(n_samples=24, n_surface_samples=8, colour_min_occupancy=0.0),
    train=TrainConfig(rays_new=128, rays_replay=128, iterations_per_view=5),
    eval=EvalConfig(n_test_views=3, image_scale=0.1, mesh_resolution=32, mesh_points=2000, render_samples=24),
    plan=PlanConfig(n_uniform=12, top_k=2, n_resample=2, candidate_scale=0.03, candidate_samples=24),
    explicit=ExplicitConfig(resolution=24, n_candidates=12, candidate_scale=0.03),  # the field's grid
)

PRESETS = {"paper": PAPER, "lite": LITE, "smoke": SMOKE}


def get_preset(name: str = "lite", **overrides) -> Preset:
    """A preset by name, optionally with whole sub-configs replaced (``train=TrainConfig(...)``)."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; choose one of {sorted(PRESETS)}")
    return replace(PRESETS[name], **overrides)


def check_device(name: str):
    """A torch device by name ("cpu", "cuda", "cuda:1"); a clear error when it does not exist here."""
    import torch

    try:
        device = torch.device(name)
    except (RuntimeError, TypeError) as err:
        raise ValueError(f"unknown device {name!r}; use 'cpu' or 'cuda' ({err})") from None
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device {name!r} asked for, but torch {torch.__version__} sees no CUDA GPU here; use 'cpu'")
    if device.type not in ("cpu", "cuda"):
        raise ValueError(f"device {name!r}: only 'cpu' and 'cuda' are supported")
    return device
