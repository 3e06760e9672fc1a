"""Evaluation as in the paper (Sec. IV-A): target-only PSNR on test views and target-mesh
precision, completeness and F1 at a 1 cm threshold. Introduced in notebook 03, used every step in 05.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch
import trimesh
from scipy.spatial import cKDTree
from skimage.measure import marching_cubes

from .classes import BACKGROUND
from .config import Preset
from .geometry import Intrinsics, test_views, view_to_pose
from .rendering import build_skip_grid, render_image
from .simulator import Simulator, target_only_image


def psnr(prediction: np.ndarray, target: np.ndarray) -> float:
    """Peak signal-to-noise ratio of images in [0, 1]: -10 log10(mean squared error) over the whole image."""
    mse = float(np.mean((np.asarray(prediction, np.float64) - np.asarray(target, np.float64)) ** 2))
    return float("inf") if mse == 0 else -10.0 * np.log10(mse)


@torch.no_grad()
def occupancy_volume(field, resolution: int, targets=None, z_min: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Occupancy on a regular (R, R, R) lattice over the cube, indexed [x, y, z], and the lattice's axis.

    Points whose semantic argmax is background (or, with ``targets``, not a target) count as empty:
    the paper's target-only mesh. ``z_min`` skips the part of the cube below it (it stays empty).
    """
    b = field.cfg.bound
    axis = np.linspace(-b, b, resolution, dtype=np.float32)
    zs = axis if z_min is None else axis[axis >= z_min - (axis[1] - axis[0])]
    grid = torch.as_tensor(np.stack(np.meshgrid(axis, axis, zs, indexing="ij"), -1).reshape(-1, 3), device=field.device)
    q = field.query(grid)
    label = q["sem"].argmax(dim=1)
    keep = label != BACKGROUND if targets is None else torch.isin(label, torch.as_tensor(targets, device=label.device))
    occ = (q["occ"] * keep).view(resolution, resolution, len(zs)).cpu().numpy()
    volume = np.zeros((resolution, resolution, resolution), np.float32)
    volume[:, :, resolution - len(zs):] = occ
    return volume, axis


def extract_mesh(field, resolution: int = 128, targets=None, threshold: float = 0.5) -> trimesh.Trimesh | None:
    """Marching cubes of the (target-only) occupancy at ``threshold`` (paper: 0.5); None when nothing is occupied."""
    volume, axis = occupancy_volume(field, resolution, targets, z_min=-0.05)
    if volume.max() <= threshold or volume.min() >= threshold:
        return None
    spacing = float(axis[1] - axis[0])
    padded = np.pad(volume, 1)  # closed surfaces at the cube's faces
    verts, faces, _, _ = marching_cubes(padded, level=threshold, spacing=(spacing,) * 3)
    verts = verts - spacing + axis[0]
    return trimesh.Trimesh(vertices=verts, faces=faces, process=False)


@dataclass
class MeshScores:
    precision: float
    completeness: float
    f1: float
    chamfer: float


def mesh_scores_from_points(pred_points: np.ndarray, gt_tree: cKDTree, gt_points: np.ndarray, threshold: float) -> MeshScores:
    """Precision, completeness, F1 (fractions in [0, 1]) and chamfer distance [m] between point samples."""
    if len(pred_points) == 0:
        return MeshScores(0.0, 0.0, 0.0, 1.0)
    d_pred, _ = gt_tree.query(pred_points, workers=-1)
    d_gt, _ = cKDTree(pred_points).query(gt_points, workers=-1)
    precision, completeness = float(np.mean(d_pred < threshold)), float(np.mean(d_gt < threshold))
    f1 = 0.0 if precision + completeness == 0 else 2 * precision * completeness / (precision + completeness)
    return MeshScores(precision, completeness, f1, float((d_pred.mean() + d_gt.mean()) / 2))


def sample_surface(mesh: trimesh.Trimesh | None, n: int, seed: int) -> np.ndarray:
    """``n`` points uniformly on a mesh's surface (seeded); none for an empty mesh."""
    if mesh is None or len(mesh.faces) == 0:
        return np.zeros((0, 3))
    points, _ = trimesh.sample.sample_surface(mesh, n, seed=seed)
    return np.asarray(points)


def mesh_scores(pred: trimesh.Trimesh | None, gt: trimesh.Trimesh, n_points: int, threshold: float, seed: int = 0) -> MeshScores:
    """Sample ``n_points`` on both meshes and score them (the paper uses 1e6 points and 1 cm)."""
    gt_points = sample_surface(gt, n_points, seed)
    return mesh_scores_from_points(sample_surface(pred, n_points, seed + 1), cKDTree(gt_points), gt_points, threshold)


class Evaluator:
    """Target-only evaluation of a map against one scene: ground truth is rendered and sampled once.

    ``evaluate(model)`` takes a SemanticField or an ExplicitMap and returns the mean target-only PSNR over the test views and the target-mesh
    precision / completeness / F1 / chamfer, plus the predicted mesh.
    """

    def __init__(self, simulator: Simulator, targets, preset: Preset, seed: int = 0):
        self.targets = simulator.scene.check_targets(targets)
        self.preset = preset
        cfg = preset.eval
        self.seed = seed
        self.intrinsics: Intrinsics = Intrinsics.from_fov().scaled(cfg.image_scale)
        self.views = test_views(cfg.n_test_views)
        self.poses = [view_to_pose(el, az) for el, az in self.views]
        measurements = [simulator.render(p, self.intrinsics) for p in self.poses]
        self.gt_images = [target_only_image(m, self.targets) for m in measurements]
        self.gt_mesh = simulator.scene.target_mesh(self.targets)
        self.gt_points = sample_surface(self.gt_mesh, cfg.mesh_points, seed)
        self.gt_tree = cKDTree(self.gt_points)

    def render_test_views(self, field, skip_empty_space: bool = True) -> list[np.ndarray]:
        """Target-only renders of the map at every test view (for a field, skipping space that holds no target)."""
        if hasattr(field, "render_target_only"):  # the explicit map renders itself
            return [field.render_target_only(self.intrinsics, p, self.targets) for p in self.poses]
        skip = build_skip_grid(field, self.targets) if skip_empty_space else None
        return [
            render_image(field, self.intrinsics, p, self.preset.render, targets=self.targets, skip=skip)["rgb"]
            for p in self.poses
        ]

    def evaluate(self, field) -> dict:
        cfg = self.preset.eval
        start = time.perf_counter()
        renders = self.render_test_views(field)
        psnrs = [psnr(r, g) for r, g in zip(renders, self.gt_images)]
        t_render = time.perf_counter() - start
        if hasattr(field, "extract_target_mesh"):
            mesh = field.extract_target_mesh(self.targets)
        else:
            mesh = extract_mesh(field, cfg.mesh_resolution, targets=self.targets)
        scores = mesh_scores_from_points(sample_surface(mesh, cfg.mesh_points, self.seed + 1), self.gt_tree, self.gt_points, cfg.f1_threshold)
        return {
            "psnr": float(np.mean(psnrs)),
            "precision": scores.precision,
            "completeness": scores.completeness,
            "f1": scores.f1,
            "chamfer": scores.chamfer,
            "mesh": mesh,
            "time_render_s": t_render,
            "time_total_s": time.perf_counter() - start,
        }
