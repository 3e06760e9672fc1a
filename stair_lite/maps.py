"""The map a mission builds, behind one small interface: the implicit map (the semantic field and its
trainer, paper Sec. III) and the explicit voxel map of the STE baseline (explicit.py, Sec. IV-C).

Introduced in notebook 05. A map takes measurements and updates itself; the evaluator asks it for
target-only renders and the target mesh; a planner reads its ``planning_source``. Its state is what
its measurements do not determine (``state_dict``): a mission resumes a map by adding the same
measurements again and then loading that state.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable
from dataclasses import replace

import numpy as np
import torch

from .config import EvalConfig, Preset
from .evaluation import extract_mesh
from .field import SemanticField
from .geometry import Intrinsics
from .measurement import Measurement
from .metrics import OCCUPIED
from .rendering import SkipGrid, build_skip_grid, render_target_views_and_cut
from .training import Losses, Trainer

IMPLICIT, EXPLICIT = "implicit", "explicit"
MAP_KINDS: dict[str, type["ReconstructionMap"]] = {}  # kind -> class, filled by ``register_map``


def register_map(cls: type["ReconstructionMap"]) -> type["ReconstructionMap"]:
    """Make a map kind available to missions (``--mapper``) and planners (``Planner.reads``), by its ``kind``; used as a
    class decorator beside the class."""
    if cls.kind in MAP_KINDS:
        raise ValueError(f"a map of kind {cls.kind!r} is already registered")
    MAP_KINDS[cls.kind] = cls
    return cls


class ReconstructionMap(ABC):
    """What a mission, its evaluator and its planner need of a map."""

    kind: str

    @classmethod
    @abstractmethod
    def from_preset(cls, preset: Preset, seed: int = 0, device="cpu") -> "ReconstructionMap":
        """The empty map of a preset; ``seed`` seeds whatever it draws at random."""

    @abstractmethod
    def add_measurement(self, m: Measurement) -> None:
        """Take a measurement into the map's memory (``update`` learns from it)."""

    @abstractmethod
    def update(self) -> list[Losses]:
        """Update the map after a new measurement; the loss history of its training, if it trains."""

    def integrate(self, m: Measurement) -> list[Losses]:
        """One step of a mission's mapping: add the measurement, then update."""
        self.add_measurement(m)
        return self.update()

    @abstractmethod
    def target_only_renders(self, intrinsics: Intrinsics, poses: list[np.ndarray], targets: tuple[int, ...],
                            z_min: float) -> Iterable[tuple[np.ndarray, np.ndarray]]:
        """Two target-only colour renders per pose, in the order of ``poses`` (paper Sec. IV-A): as the paper
        defines them, and with nothing below height ``z_min`` (the unobservable volume under the ground)."""

    @abstractmethod
    def target_mesh(self, targets: tuple[int, ...]):
        """The target-only surface as a trimesh (None when nothing is occupied)."""

    @abstractmethod
    def occupied_share_below(self, z_max: float) -> float:
        """The share of the map's lattice points below height ``z_max`` with occupancy above ``OCCUPIED`` (0.5): under
        the ground no view can see and the scene is empty, so anything there is invented (a phantom)."""

    @property
    @abstractmethod
    def planning_source(self):
        """What a planner of this map's kind reads (``Planner.reads``): the implicit map gives its ``SemanticField``
        (planners call ``query`` on points and read ``lattice``, ``reached``, ``device``); the explicit map gives
        itself (STE's planner calls ``roi_scores``)."""

    def state_dict(self) -> dict:
        return {}

    def load_state_dict(self, state: dict) -> None:
        pass


@register_map
class ImplicitMap(ReconstructionMap):
    """The semantic field and its incremental trainer: STAIR's map. Planners read the field."""

    kind = IMPLICIT

    def __init__(self, trainer: Trainer, eval_cfg: EvalConfig):
        self.trainer = trainer
        self.eval_cfg = eval_cfg  # the target mesh's lattice and the evaluation renders' samples per ray
        self._target_skip = None  # (key, SkipGrid): built once per state of the field (its training iteration)

    @classmethod
    def from_preset(cls, preset: Preset, seed: int = 0, device="cpu") -> "ImplicitMap":
        field = SemanticField(preset.field, seed=seed).to(device)
        return cls(Trainer(field, preset.train, preset.render, seed=seed), preset.eval)

    @property
    def field(self) -> SemanticField:
        return self.trainer.field

    def add_measurement(self, m: Measurement) -> None:
        self.trainer.add_measurement(m)

    def update(self) -> list[Losses]:
        return self.trainer.update()

    def target_skip_grid(self, targets) -> SkipGrid:
        """The lattice cells that may hold a target (``build_skip_grid``), built once per training iteration of
        the field (a field changed by hand needs ``build_skip_grid`` itself)."""
        key = (tuple(targets), self.trainer.iterations)
        if self._target_skip is None or self._target_skip[0] != key:
            self._target_skip = (key, build_skip_grid(self.field, targets))
        return self._target_skip[1]

    def target_only_renders(self, intrinsics, poses, targets, z_min):
        """Both renders skip the lattice cells that hold no target (``target_skip_grid``); the second also
        the cells below ``z_min``. Both come from one evaluation of the field per sample."""
        skip = self.target_skip_grid(targets)
        render_cfg = replace(self.trainer.render_cfg, n_samples=self.eval_cfg.render_samples)
        return render_target_views_and_cut(self.field, intrinsics, poses, render_cfg, targets, skip, z_min)

    def target_mesh(self, targets):
        """Marching cubes of the target-masked occupancy; the field is evaluated only in the lattice cells that
        may hold a target (``target_skip_grid``, threshold 1e-3, far below the 0.5 level)."""
        return extract_mesh(self.field, self.eval_cfg.mesh_resolution, targets=targets, skip=self.target_skip_grid(targets))

    def occupied_share_below(self, z_max):
        """With occupancy only where a ray reached (``FieldConfig.reached_only``), a vertex no ray reached has o = 0
        exactly (its own trilinear weight is 1), so only the reached vertices below ``z_max`` are queried: under the
        ground, few or none."""
        points = self.field.lattice.points(self.field.device)
        below = points[:, 2] < z_max
        if not below.any():
            return 0.0
        queried = below & self.field.reached if self.field.cfg.reached_only else below
        occupied = torch.zeros(int(below.sum()), dtype=torch.bool, device=points.device)
        if queried.any():
            occupied[queried[below]] = self.field.query(points[queried])["occ"] > OCCUPIED
        return float(occupied.float().mean())

    @property
    def planning_source(self) -> SemanticField:
        return self.field

    def state_dict(self) -> dict:
        return {"field": self.field.state_dict(), "trainer": self.trainer.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        self._target_skip = None
        self.field.load_state_dict(state["field"])
        self.trainer.load_state_dict(state["trainer"])


from . import explicit  # noqa: E402,F401  (registers the explicit map kind beside its class)
