"""The explicit baseline STE (paper Sec. IV-C, after Zaenker et al., IROS 2021 [tobias2021iros]
in REFERENCES.md): a semantic
occupancy voxel map updated by casting measured rays, and its region-of-interest planner.

Introduced in notebook 06. The map keeps, per voxel, occupancy log-odds updated as OctoMap does
(free along each ray, occupied at its end point, each voxel at most once per scan, occupied winning,
values clamped), per-class hit counts (semantic fusion) and a running mean colour. Target meshes and
target-only colour renders come from the map, so STE is scored with the same metrics as STAIR.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch
from scipy.ndimage import distance_transform_edt

from .classes import NUM_CLASSES
from .config import ExplicitConfig, Preset
from .geometry import Intrinsics, pixel_rays, view_to_pose
from .lattice import VoxelGrid, xyz
from .maps import EXPLICIT, ReconstructionMap, register_map
from .measurement import Measurement
from .metrics import OCCUPIED
from .rendering import ray_box_intersection
from .training import Losses


RENDER_CHUNK_RAYS = 8192  # rays marched at once in a target-only render


def logit(p: float) -> float:
    return float(np.log(p / (1.0 - p)))


class Scan(NamedTuple):
    """The voxels one measurement updates (flat indices): ``crossed`` and ``hit`` once each (a voxel may be in
    both); per ray end point inside the grid, its voxel, class and colour."""

    crossed: torch.Tensor
    hit: torch.Tensor
    end_voxels: torch.Tensor
    end_labels: torch.Tensor
    end_colours: torch.Tensor


def octomap_update(log_odds: torch.Tensor, crossed: torch.Tensor, hit: torch.Tensor, l_hit: float, l_miss: float,
                   l_min: float, l_max: float) -> None:
    """OctoMap's update of one scan, in place [hornung2013octomap]: every voxel a ray crossed adds ``l_miss``,
    every voxel a ray ended in adds ``l_hit``, each voxel at most once per scan and a voxel both crossed and hit
    counting as hit; log-odds stay within [l_min, l_max] so that a voxel can still change its mind."""
    free = crossed[~torch.isin(crossed, hit)]
    log_odds[free] = (log_odds[free] + l_miss).clamp(l_min, l_max)
    log_odds[hit] = (log_odds[hit] + l_hit).clamp(l_min, l_max)


@register_map
class ExplicitMap(ReconstructionMap):
    """A semantic occupancy grid over the scene cube, on a ``VoxelGrid`` (voxel (i, j, k) covers
    x in [-b + i v, -b + (i+1) v)). Planners (STE's) read the map itself.

    Its state is a function of its measurements (integration is deterministic), so ``state_dict`` is
    empty: a resumed mission rebuilds the map by integrating the same measurements again."""

    kind = EXPLICIT

    def __init__(self, cfg: ExplicitConfig = ExplicitConfig(), device: str | torch.device = "cpu"):
        self.cfg = cfg
        r = cfg.resolution
        self.grid = VoxelGrid(r, cfg.bound)
        self.voxel = self.grid.voxel
        self.device = torch.device(device)
        self.log_odds = torch.zeros(r**3, device=self.device)
        self.observed = torch.zeros(r**3, dtype=torch.bool, device=self.device)
        self.class_counts = torch.zeros(r**3, NUM_CLASSES, device=self.device)
        self.colour_sum = torch.zeros(r**3, 3, device=self.device)
        self.l_hit, self.l_miss = logit(cfg.prob_hit), logit(cfg.prob_miss)
        self.l_min, self.l_max = logit(cfg.clamp_min), logit(cfg.clamp_max)

    @classmethod
    def from_preset(cls, preset: Preset, seed: int = 0, device="cpu") -> "ExplicitMap":
        """The map of a preset (integration draws nothing at random: ``seed`` is not used)."""
        return cls(preset.explicit, device=device)

    # ------------------------------------------------------------------ indexing
    def voxel_index(self, points: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Flat voxel indices of points (..., 3) and whether each lies inside the grid."""
        return self.grid.cell_index(points)

    def _march(self, origins: torch.Tensor, dirs: torch.Tensor, t_end: torch.Tensor | None = None, step_voxels: float = 0.5,
               within: tuple[torch.Tensor, torch.Tensor] | None = None):
        """Flat voxel indices (R, S) along rays from the cube entry to ``t_end`` (or the exit), sampled
        every ``step_voxels`` voxels, and which samples are valid (on the ray's stretch inside the cube).
        ``within``: a box (low, high): only the samples near it, at the same ray parameters as without it."""
        t_near, t_far, hit = ray_box_intersection(origins, dirs, self.grid.bound, near=0.0)
        if t_end is not None:
            t_far = torch.minimum(t_far, t_end)
        o, d = self.grid.to_voxel_units(origins), dirs / self.voxel
        step = step_voxels / d.norm(dim=1)
        first = torch.zeros(len(origins), dtype=torch.long, device=self.device)  # the first sample's number
        if within is not None:  # from the last sample before the box to the first after it
            b_near, b_far, b_hit = ray_box_intersection(origins, dirs, within[1], near=0.0, low=within[0])
            hit = hit & b_hit
            first = ((b_near - t_near) / step).floor().clamp(min=0).long()
            t_far = torch.minimum(t_far, b_far + step)
        span = (t_far - t_near) / step - first
        n = int(torch.ceil(span.clamp(min=0).max()).item()) + 1 if len(origins) else 1
        t = t_near[:, None] + step[:, None] * (first[:, None] + torch.arange(n, device=self.device))
        valid = hit[:, None] & (t < t_far[:, None])
        index, _ = self.grid.flat_from_voxel_units(o[:, None, :] + t[..., None] * d[:, None, :])
        return index, valid

    # ------------------------------------------------------------------ mapping
    def scan_voxels(self, m: Measurement) -> Scan:
        """The voxels one measurement updates: those its rays cross and those its rays end in, each once."""
        s = self.cfg.pixel_stride
        origins, dirs = pixel_rays(m.intrinsics, m.pose)
        keep = np.zeros((m.intrinsics.height, m.intrinsics.width), dtype=bool)
        keep[::s, ::s] = True
        keep = keep.reshape(-1)
        as_tensor = lambda a, **kw: torch.as_tensor(a, device=self.device, **kw)  # noqa: E731
        origins, dirs = as_tensor(origins[keep], dtype=torch.float32), as_tensor(dirs[keep], dtype=torch.float32)
        depth = as_tensor(m.depth.reshape(-1)[keep])
        labels, rgb = as_tensor(m.labels.reshape(-1)[keep]), as_tensor(m.rgb.reshape(-1, 3)[keep])
        hit = depth > 0
        rays = slice(None) if self.cfg.carve_background else hit  # rays that integrate free space
        t_end = torch.where(hit, depth, torch.full_like(depth, float("inf")))[rays]
        index, valid = self._march(origins[rays], dirs[rays], t_end)
        end_index, end_inside = self.voxel_index(origins[hit] + depth[hit, None] * dirs[hit])
        return Scan(torch.unique(index[valid]), torch.unique(end_index[end_inside]), end_index[end_inside],
                    labels[hit][end_inside], rgb[hit][end_inside])

    def add_measurement(self, m: Measurement) -> None:
        """Fuse one measurement: free space along every ray, occupied and labelled at its end point."""
        scan = self.scan_voxels(m)
        octomap_update(self.log_odds, scan.crossed, scan.hit, self.l_hit, self.l_miss, self.l_min, self.l_max)
        self.observed[scan.crossed] = True
        self.observed[scan.hit] = True
        ones = torch.ones(len(scan.end_voxels), device=self.device)
        self.class_counts.index_put_((scan.end_voxels, scan.end_labels), ones, accumulate=True)
        self.colour_sum.index_add_(0, scan.end_voxels, scan.end_colours)

    def update(self) -> list[Losses]:
        """Nothing to learn: a measurement is fused as it is added."""
        return []

    # ------------------------------------------------------------------ queries
    @property
    def probability(self) -> torch.Tensor:
        """Occupancy probability per voxel (0.5 where never observed)."""
        return torch.sigmoid(self.log_odds)

    @property
    def labels(self) -> torch.Tensor:
        """Fused class per voxel: the most frequent label among its hits (background when never hit)."""
        return self.class_counts.argmax(dim=1)

    @property
    def colours(self) -> torch.Tensor:
        hits = self.class_counts.sum(dim=1, keepdim=True)
        return torch.where(hits > 0, self.colour_sum / hits.clamp(min=1), torch.ones_like(self.colour_sum))

    def target_occupancy(self, targets) -> np.ndarray:
        """Occupancy probability with every non-target voxel set to 0, as an (R, R, R) array indexed [x, y, z]."""
        r = self.cfg.resolution
        keep = torch.isin(self.labels, torch.as_tensor(targets, device=self.device))
        return xyz((self.probability * keep).view(r, r, r)).cpu().numpy()

    def extract_target_mesh(self, targets, threshold: float = OCCUPIED):
        """Marching cubes of the target-only occupancy, on voxel centres (None when nothing is occupied)."""
        import trimesh
        from skimage.measure import marching_cubes

        volume = self.target_occupancy(targets)
        if volume.max() <= threshold:
            return None
        verts, faces, _, _ = marching_cubes(np.pad(volume, 1), level=threshold, spacing=(self.voxel,) * 3)
        verts = verts - self.voxel + self.grid.first_centre()
        return trimesh.Trimesh(vertices=verts, faces=faces, process=False)

    def target_mesh(self, targets):
        return self.extract_target_mesh(targets)

    def occupied_share_below(self, z_max):
        r = self.cfg.resolution
        centres_z = self.grid.first_centre() + self.voxel * torch.arange(r, device=self.device)
        layers = int((centres_z < z_max).sum())
        return float((self.probability.view(r, r, r)[:layers] > OCCUPIED).float().mean()) if layers else 0.0

    def target_only_renders(self, intrinsics, poses, targets, z_min):
        """First-hit renders; the same images twice: the map holds only voxels it has seen occupied, so
        there is no unobserved volume under the ground to cut. The target voxels and their colours are read once
        for all the views."""
        voxels = self._target_voxels(targets)
        for pose in poses:
            render = self._first_hit_colours(intrinsics, pose, *voxels)
            yield render, render

    @property
    def planning_source(self) -> "ExplicitMap":
        return self

    @torch.no_grad()
    def render_target_only(self, intrinsics: Intrinsics, pose: np.ndarray, targets) -> np.ndarray:
        """Colour of the first occupied (p > 0.5) target voxel along each pixel's ray; white elsewhere.

        As for the field, non-target voxels count as empty (paper Sec. IV-A's target-only renders).
        """
        return self._first_hit_colours(intrinsics, pose, *self._target_voxels(targets))

    def _box_around(self, voxels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor] | None:
        """World-coordinate corners (low, high) of the box around the set voxels, one voxel wider on every side
        (None when none is set)."""
        r = self.cfg.resolution
        cells = torch.nonzero(xyz(voxels.view(r, r, r)))  # (N, 3) cell coordinates i, j, k
        if len(cells) == 0:
            return None
        low = -self.grid.bound + self.voxel * (cells.amin(dim=0) - 1).float()
        high = -self.grid.bound + self.voxel * (cells.amax(dim=0) + 2).float()
        return low, high

    def _target_voxels(self, targets) -> tuple[torch.Tensor, torch.Tensor, tuple[torch.Tensor, torch.Tensor] | None]:
        """Which voxels are occupied (p > 0.5) target voxels, every voxel's colour, and the box around the first."""
        solid = (self.probability > OCCUPIED) & torch.isin(self.labels, torch.as_tensor(targets, device=self.device))
        return solid, self.colours, self._box_around(solid)

    @torch.no_grad()
    def _first_hit_colours(self, intrinsics: Intrinsics, pose: np.ndarray, solid: torch.Tensor, colours: torch.Tensor,
                           box: tuple[torch.Tensor, torch.Tensor] | None, chunk_rays: int = RENDER_CHUNK_RAYS) -> np.ndarray:
        """The first-hit image, ``chunk_rays`` rays at a time (each ray on its own: chunks change no pixel; a
        400 x 400 image marched at once would hold about 70 M samples), each ray sampled only near the box of the
        target voxels (no sample outside it can be one: the same first hits)."""
        origins, dirs = pixel_rays(intrinsics, pose)
        origins = torch.as_tensor(origins, dtype=torch.float32, device=self.device)
        dirs = torch.as_tensor(dirs, dtype=torch.float32, device=self.device)
        image = torch.ones(len(origins), 3, device=self.device)
        if box is None:
            return image.view(intrinsics.height, intrinsics.width, 3).cpu().numpy()
        for start in range(0, len(origins), chunk_rays):
            index, valid = self._march(origins[start : start + chunk_rays], dirs[start : start + chunk_rays], within=box)
            hit = solid[index] & valid
            first = hit.float().argmax(dim=1)
            found = hit.any(dim=1)
            image[start : start + chunk_rays][found] = colours[index[found, first[found]]]
        return image.view(intrinsics.height, intrinsics.width, 3).cpu().numpy()

    # ------------------------------------------------------------------ planning (the ROI utility)
    @torch.no_grad()
    def roi_scores(self, views: np.ndarray, targets) -> np.ndarray:
        """STE's utility of each view: over its rays, up to and including the first occupied voxel, the
        unknown voxels score 0.5 plus up to 0.5 more the closer they lie to a target voxel (within
        ``roi_max_distance`` voxels); a ray's score is normalised by its number of in-grid samples,
        and a view's utility is the sum over its rays (the reference code's ROI utility)."""
        cfg, r = self.cfg, self.cfg.resolution
        roi = torch.isin(self.labels, torch.as_tensor(targets, device=self.device)) & (self.probability > OCCUPIED)
        if roi.any():
            distance = distance_transform_edt(~roi.view(r, r, r).cpu().numpy())
            bonus = np.maximum(0.0, 0.5 * (cfg.roi_max_distance - distance) / cfg.roi_max_distance)
            bonus = torch.as_tensor(bonus.reshape(-1), dtype=torch.float32, device=self.device)
        else:
            bonus = torch.zeros(r**3, device=self.device)
        # one table: the score of an unknown voxel, 0 for a known free one, -1 marks an occupied one
        table = torch.where(self.observed, torch.zeros(1, device=self.device), 0.5 + bonus)
        table = torch.where(self.probability > OCCUPIED, torch.full_like(table, -1.0), table)
        k = Intrinsics.from_fov().scaled(cfg.candidate_scale)
        scores = []
        for start in range(0, len(views), 25):
            rays = [pixel_rays(k, view_to_pose(el, az)) for el, az in views[start : start + 25]]
            origins = torch.as_tensor(np.concatenate([o for o, _ in rays]), dtype=torch.float32, device=self.device)
            dirs = torch.as_tensor(np.concatenate([d for _, d in rays]), dtype=torch.float32, device=self.device)
            index, valid = self._march(origins, dirs, step_voxels=1.0)
            value = table[index] * valid
            blocked = (value < 0).int()
            counted = (torch.cumsum(blocked, dim=1) - blocked) == 0  # up to and including the first occupied voxel
            ray_score = (value.clamp(min=0) * counted).sum(dim=1) / valid.sum(dim=1).clamp(min=1)
            scores.append(ray_score.view(-1, k.width * k.height).sum(dim=1).cpu().numpy())
        return np.concatenate(scores)
