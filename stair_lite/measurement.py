"""The Measurement record (one posed RGB-D image with semantic labels) and its back-projection.

Introduced in notebook 01. Images follow the conventions (README, Design): rgb float32 (H, W, 3) in [0, 1]; depth float32
z-depth in metres with 0 where nothing was hit; labels integer class ids.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from .classes import NUM_CLASSES
from .geometry import Intrinsics, pixel_rays


@dataclass(frozen=True)
class Measurement:
    """One posed RGB-D measurement with per-pixel class labels. Checked on construction."""

    rgb: np.ndarray
    depth: np.ndarray
    labels: np.ndarray
    pose: np.ndarray
    intrinsics: Intrinsics

    def __post_init__(self):
        h, w = self.intrinsics.height, self.intrinsics.width
        for name, shape in (("rgb", (h, w, 3)), ("depth", (h, w)), ("labels", (h, w))):
            got = np.shape(getattr(self, name))
            if got != shape:
                raise ValueError(f"measurement {name} has shape {got}, but the intrinsics ({w}x{h}) need {shape}")
        if np.shape(self.pose) != (4, 4) or not np.all(np.isfinite(self.pose)):
            raise ValueError(f"measurement pose must be a finite 4x4 matrix, got shape {np.shape(self.pose)}")
        depth = np.asarray(self.depth)
        if not np.all(np.isfinite(depth)):
            raise ValueError(f"measurement depth contains {int(np.sum(~np.isfinite(depth)))} NaN or infinite values")
        if depth.min() < 0:
            raise ValueError(f"measurement depth must be >= 0 (0 = no hit), found minimum {depth.min()!r}")
        rgb = np.asarray(self.rgb)
        if not np.all(np.isfinite(rgb)) or rgb.min() < 0 or rgb.max() > 1:
            raise ValueError(f"measurement rgb must lie in [0, 1], found range [{rgb.min()!r}, {rgb.max()!r}]")
        labels = np.asarray(self.labels)
        if not np.issubdtype(labels.dtype, np.integer):
            raise ValueError(f"measurement labels must be integer class ids, got dtype {labels.dtype}")
        if labels.min() < 0 or labels.max() >= NUM_CLASSES:
            raise ValueError(
                f"measurement labels must lie in the class range 0..{NUM_CLASSES - 1}, found [{labels.min()}, {labels.max()}]"
            )


def measured_rays(m: Measurement, device="cpu") -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Every pixel's ray as float32 tensors: origins (H*W, 3), directions (H*W, 3) and measured z-depth (H*W,)."""
    origins, directions = pixel_rays(m.intrinsics, m.pose)
    return tuple(torch.as_tensor(a, dtype=torch.float32, device=device) for a in (origins, directions, m.depth.reshape(-1)))


def back_project(m: Measurement) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points (N, 3), colours (N, 3) and labels (N,) of every pixel with a depth hit.

    Each pixel's ray has camera-frame z component 1, so the point is origin + depth * direction.
    """
    origins, directions = pixel_rays(m.intrinsics, m.pose)
    depth = m.depth.reshape(-1)
    hit = depth > 0
    points = origins[hit] + depth[hit, None] * directions[hit]
    return points, m.rgb.reshape(-1, 3)[hit], m.labels.reshape(-1)[hit]
