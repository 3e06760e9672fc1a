"""Evaluation as in the paper (Sec. IV-A): target-only PSNR on test views and target-mesh
precision, completeness and F1 at a 1 cm threshold. Introduced in notebook 03, used every step in 05.

Two target-only PSNRs are reported. ``psnr`` follows the paper's protocol as stated: the map's
render with non-target samples deleted against the measured image with non-target pixels blanked.
It compares unlike with unlike where another object hides a target (the render shows the target,
the image does not) and where the render looks through the deleted ground into the volume below it,
which no view observes (the field fills it). ``psnr_clean`` removes both (notebook 08 measures them):
its ground truth is the target objects rendered alone, and the field's samples below ``GROUND_CUT_Z``
are ignored, as the mesh metric ignores them. It averages over the test views that show a target.
"""
from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import torch
import trimesh
from scipy.spatial import cKDTree
from skimage.measure import marching_cubes

from .allocator import release_freed_memory
from .classes import BACKGROUND
from .config import Preset
from .geometry import Intrinsics, test_views, view_to_pose
from .lattice import Lattice, xyz
from .metrics import OCCUPIED
from .simulator import Simulator, target_only_image

GROUND_CUT_Z = -0.05  # the ground's top is z = 0; nothing below it is observable, so metrics ignore it
QUERY_CHUNK = 262144  # lattice points queried at once when a volume is evaluated


def f1_column(threshold: float) -> str:
    """The record column of the F1 score at a threshold [m]: ``f1_2cm``."""
    return f"f1_{threshold * 100:g}cm"


def psnr(prediction: np.ndarray, target: np.ndarray) -> float:
    """Peak signal-to-noise ratio of images in [0, 1]: -10 log10(mean squared error) over the whole image."""
    mse = float(np.mean((np.asarray(prediction, np.float64) - np.asarray(target, np.float64)) ** 2))
    return float("inf") if mse == 0 else -10.0 * np.log10(mse)


@torch.no_grad()
def occupancy_volume(field, resolution: int, targets=None, z_min: float | None = None,
                     skip=None) -> tuple[np.ndarray, Lattice]:
    """Occupancy on a ``Lattice`` of ``resolution``^3 vertices over the cube, as an (R, R, R) volume indexed
    [x, y, z], and the lattice.

    Points whose semantic argmax is background (or, with ``targets``, not a target) count as empty:
    the paper's target-only mesh. ``z_min`` skips the layers below it (they stay empty). ``skip`` (a
    ``SkipGrid`` of the field, built with the same ``targets``): points in cells it leaves out count as
    empty without evaluating the field (its occupancy there is below the skip grid's threshold); only the vertices in
    the box of its kept cells are looked at.
    """
    lattice = Lattice(resolution, field.lattice.bound)
    low = torch.full((3,), -lattice.bound)
    high = torch.full((3,), lattice.bound)
    if z_min is not None:
        low[2] = lattice.axis()[lattice.first_layer(z_min)]
    if skip is not None:  # only the vertices in the box of the skip grid's kept cells can be evaluated
        box = skip.box
        if box is None:
            return np.zeros((resolution,) * 3, np.float32), lattice
        low, high = torch.maximum(low, box[0].cpu()), torch.minimum(high, box[1].cpu())
    block = lattice.block(low, high)
    points = lattice.block_points(block, field.device)
    evaluate = skip.lookup(points) if skip is not None else torch.ones(len(points), dtype=torch.bool, device=field.device)
    occ = torch.zeros(len(points), device=field.device)
    wanted = None if targets is None else torch.as_tensor(targets, device=field.device)
    for part in torch.split(evaluate.nonzero().squeeze(1), QUERY_CHUNK):  # in chunks: 256^3 x 7 probabilities is 0.5 GB
        q = field.query(points[part])
        label = q["sem"].argmax(dim=1)
        keep = label != BACKGROUND if wanted is None else torch.isin(label, wanted)
        occ[part] = q["occ"] * keep
    volume = np.zeros((resolution,) * 3, np.float32)  # indexed [z, y, x], the lattice's flat order
    z, y, x = block[::-1]
    volume[z, y, x] = occ.view(z.stop - z.start, y.stop - y.start, x.stop - x.start).cpu().numpy()
    return xyz(volume), lattice


def extract_mesh(field, resolution: int = 128, targets=None, threshold: float = OCCUPIED, skip=None) -> trimesh.Trimesh | None:
    """Marching cubes of the (target-only) occupancy at ``threshold`` (paper: 0.5); None when nothing is occupied.
    ``skip``: see ``occupancy_volume``."""
    volume, lattice = occupancy_volume(field, resolution, targets, z_min=GROUND_CUT_Z, skip=skip)
    if volume.max() <= threshold or volume.min() >= threshold:
        return None
    padded = np.pad(volume, 1)  # closed surfaces at the cube's faces
    verts, faces, _, _ = marching_cubes(padded, level=threshold, spacing=(lattice.spacing,) * 3)
    verts = verts - lattice.spacing - lattice.bound
    return trimesh.Trimesh(vertices=verts, faces=faces, process=False)


@dataclass
class MeshScores:
    """Precision, completeness and F1 at the threshold; chamfer distance [m]; F1 at further thresholds
    (``f1_at``, keyed by the threshold in metres)."""

    precision: float
    completeness: float
    f1: float
    chamfer: float
    f1_at: dict[float, float] = field(default_factory=dict)


def f1_score(precision: float, completeness: float) -> float:
    """The harmonic mean of precision and completeness (0 when both are 0)."""
    return 0.0 if precision + completeness == 0 else 2 * precision * completeness / (precision + completeness)


def spatial_order(points: np.ndarray, cell: float = 0.02) -> np.ndarray:
    """A permutation that lists the points cell by cell of a grid of ``cell`` [m]: layer by layer in z, row by row in
    y within a layer, along x within a row. Surface samples come in random order; nearest-neighbour queries taken in
    this order visit the same tree nodes one after another, which stay in the CPU's cache (on the 1e6 samples of a
    paper-preset evaluation about 3x faster)."""
    if len(points) == 0:
        return np.zeros(0, dtype=np.int64)
    cells = np.floor((points - points.min(axis=0)) / cell).astype(np.int64)
    return np.lexsort((cells[:, 0], cells[:, 1], cells[:, 2]))


def point_tree(points: np.ndarray, order: np.ndarray | None = None) -> cKDTree:
    """A KD-tree for nearest-neighbour distances between surface samples, built on the points in ``spatial_order``
    (its leaves' points then lie together in memory). scipy's defaults (balanced splits at the
    median, node boxes shrunk to their points, 16 points per leaf) make a query slow when its nearest sample is far
    away, as it is for the ground truth's points on sides a map has not yet reconstructed: on a paper-preset map after
    three views, 0.8 ms per query against 0.03 ms with sliding-midpoint splits, unshrunk boxes and 64 points per leaf
    (benchmarks/bench_evaluation.py). The nearest distances are the same: only the search differs. The tree's indices
    refer to the points in spatial order: use it for distances. ``order``: the points' ``spatial_order``, when known."""
    order = spatial_order(points) if order is None else order
    return cKDTree(points[order], leafsize=64, compact_nodes=False, balanced_tree=False)


def nearest_distances(tree: cKDTree, queries: np.ndarray, order: np.ndarray | None = None) -> np.ndarray:
    """The distance from each query point to its nearest point in ``tree``, in the queries' order (they are
    queried in ``spatial_order``, or ``order`` when given: the same distances, faster)."""
    distances = np.empty(len(queries))
    if len(queries):
        order = spatial_order(queries) if order is None else order
        distances[order] = tree.query(queries[order], workers=-1)[0]
    return distances


def mesh_scores_from_points(pred_points: np.ndarray, gt_tree: cKDTree, gt_points: np.ndarray, threshold: float,
                            more_thresholds: tuple[float, ...] = (), gt_order: np.ndarray | None = None) -> MeshScores:
    """Precision, completeness, F1 (fractions in [0, 1]) and chamfer distance [m] between point samples;
    F1 also at ``more_thresholds`` (the distances are computed once). ``gt_order``: the ground truth's
    ``spatial_order``, when known (an evaluator computes it once)."""
    if len(pred_points) == 0:
        return MeshScores(0.0, 0.0, 0.0, 1.0, dict.fromkeys(more_thresholds, 0.0))
    pred_order = spatial_order(pred_points)  # for both the predicted points' tree and their queries
    d_pred = nearest_distances(gt_tree, pred_points, pred_order)
    d_gt = nearest_distances(point_tree(pred_points, pred_order), gt_points, gt_order)
    precision, completeness = float(np.mean(d_pred < threshold)), float(np.mean(d_gt < threshold))
    f1_at = {t: f1_score(float(np.mean(d_pred < t)), float(np.mean(d_gt < t))) for t in more_thresholds}
    return MeshScores(precision, completeness, f1_score(precision, completeness), float((d_pred.mean() + d_gt.mean()) / 2), f1_at)


def sample_surface(mesh: trimesh.Trimesh | None, n: int, seed: int) -> np.ndarray:
    """``n`` points uniformly on a mesh's surface (seeded); none for an empty mesh."""
    if mesh is None or len(mesh.faces) == 0:
        return np.zeros((0, 3))
    points, _ = trimesh.sample.sample_surface(mesh, n, seed=seed)
    return np.asarray(points)


def mesh_scores(pred: trimesh.Trimesh | None, gt: trimesh.Trimesh, n_points: int, threshold: float, seed: int = 0) -> MeshScores:
    """Sample ``n_points`` on both meshes and score them (the paper uses 1e6 points and 1 cm)."""
    gt_points = sample_surface(gt, n_points, seed)
    return mesh_scores_from_points(sample_surface(pred, n_points, seed + 1), point_tree(gt_points), gt_points, threshold)


class EightBitImages(Sequence):
    """Images in [0, 1] kept at 8 bits per channel and returned as float32 on access. The renderer's colours are
    8-bit, so this is exact, and a quarter of the memory (the paper's 200 ground-truth images: 96 MB, not 384)."""

    def __init__(self, images):
        self._stored = [np.round(np.asarray(image) * 255.0).astype(np.uint8) for image in images]

    def __len__(self) -> int:
        return len(self._stored)

    def __getitem__(self, i: int) -> np.ndarray:
        return self._stored[i].astype(np.float32) / 255.0


class Evaluator:
    """Target-only evaluation of a map against one scene: ground truth is rendered and sampled once.

    ``evaluate(map)`` takes a map (maps.py) and returns the mean target-only PSNR over the test views
    (``psnr``, the paper's; ``psnr_clean``), the target-mesh precision / completeness / F1 / chamfer, F1 at
    the further thresholds (``f1_2cm``, ``f1_5cm``), the share of the unobservable volume under the
    ground that the map fills (``phantom``), and the predicted mesh.
    """

    def __init__(self, simulator: Simulator, targets, preset: Preset, seed: int = 0):
        self.targets = simulator.scene.check_targets(targets)
        self.preset = preset
        cfg = preset.eval
        self.seed = seed
        self.intrinsics: Intrinsics = Intrinsics.from_fov().scaled(cfg.image_scale)
        self.views = test_views(cfg.n_test_views)
        self.poses = [view_to_pose(el, az) for el, az in self.views]
        alone = Simulator(simulator.scene.targets_alone(self.targets))
        # one view at a time: only the two target-only images of each test view are kept, at 8 bits
        self.gt_images = EightBitImages(target_only_image(simulator.render(p, self.intrinsics), self.targets)
                                        for p in self.poses)
        self.gt_alone_images = EightBitImages(target_only_image(alone.render(p, self.intrinsics), self.targets)
                                              for p in self.poses)
        self.views_with_targets = [i for i, g in enumerate(self.gt_alone_images) if (g < 1).any()]
        self.gt_mesh = simulator.scene.target_mesh(self.targets)
        self.gt_points = sample_surface(self.gt_mesh, cfg.mesh_points, seed)
        self.gt_order = spatial_order(self.gt_points)
        self.gt_tree = point_tree(self.gt_points, self.gt_order)

    def blank_psnr(self) -> float:
        """The paper's target-only PSNR of an all-white render over the test views that show a target (on the others a
        blank render is perfect): the floor every map should clear (notebook 08)."""
        return float(np.mean([psnr(np.ones_like(g), g) for g in self.gt_images if (g < 1).any()]))

    def evaluate(self, reconstruction) -> dict:
        """Score a map (any ``maps.ReconstructionMap``): both target-only PSNRs and the target mesh."""
        cfg = self.preset.eval
        start = time.perf_counter()
        psnrs, psnrs_clean = [], []
        renders = reconstruction.target_only_renders(self.intrinsics, self.poses, self.targets, z_min=GROUND_CUT_Z)
        for i, (render, cut) in enumerate(renders):  # one view at a time: the renders are not kept
            psnrs.append(psnr(render, self.gt_images[i]))
            if i in self.views_with_targets:
                psnrs_clean.append(psnr(cut, self.gt_alone_images[i]))
        psnr_clean = float(np.mean(psnrs_clean))
        t_render = time.perf_counter() - start
        release_freed_memory()  # the renders' working memory, before the mesh's (allocator.py)
        mesh = reconstruction.target_mesh(self.targets)
        scores = mesh_scores_from_points(sample_surface(mesh, cfg.mesh_points, self.seed + 1), self.gt_tree,
                                         self.gt_points, cfg.f1_threshold, cfg.more_f1_thresholds, self.gt_order)
        return {
            "psnr": float(np.mean(psnrs)),
            "psnr_clean": psnr_clean,
            "precision": scores.precision,
            "completeness": scores.completeness,
            "f1": scores.f1,
            "chamfer": scores.chamfer,
            **{f1_column(t): f for t, f in scores.f1_at.items()},
            "phantom": reconstruction.occupied_share_below(GROUND_CUT_Z),
            "mesh": mesh,
            "time_render_s": t_render,
            "time_total_s": time.perf_counter() - start,
        }
