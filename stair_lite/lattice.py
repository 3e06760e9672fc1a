"""The scene cube and the regular lattices laid over it: one index order for every grid in the package.

Introduced in notebook 02. The scene lives in the cube [-CUBE_BOUND, CUBE_BOUND]^3. A ``Lattice`` of
resolution R has R^3 vertices on the cube's corners and faces (vertex i at x = -b + i 2b / (R - 1), the
convention of ``F.grid_sample(..., align_corners=True)``); a ``VoxelGrid`` of resolution R cuts the cube
into R^3 cells (cell i covers [-b + i v, -b + (i + 1) v), v = 2b / R). Both store their values in one
flat order: row (k R + j) R + i holds vertex or cell (x_i, y_j, z_k), so reshaping a flat table to
(R, R, R) indexes it [z, y, x]. ``xyz`` turns such a volume into [x, y, z] order (marching cubes'
axes are then world x, y, z).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

CUBE_BOUND = 1.5  # [m]: the scene cube is [-CUBE_BOUND, CUBE_BOUND]^3 (the ground's slab fills its floor)


def flat_index(i: torch.Tensor, j: torch.Tensor, k: torch.Tensor, resolution: int) -> torch.Tensor:
    """Row of vertex or cell (i, j, k) in a flat (R^3, ...) table: (k R + j) R + i."""
    return (k * resolution + j) * resolution + i


def flat_index_of_whole_floats(ijk: torch.Tensor, resolution: int) -> torch.Tensor:
    """``flat_index`` of float coordinates (..., 3) that hold whole numbers in [0, R), as one float product: exact, since
    every partial sum is an integer below 2^24 (R up to 256), and without three integer copies of a large array."""
    return (ijk @ torch.tensor([1.0, resolution, resolution * resolution], dtype=ijk.dtype, device=ijk.device)).long()


def xyz(volume_zyx):
    """A (R, R, R) volume indexed [z, y, x] (a reshaped flat table) as one indexed [x, y, z]."""
    return volume_zyx.transpose(2, 1, 0) if isinstance(volume_zyx, np.ndarray) else volume_zyx.permute(2, 1, 0)


@dataclass(frozen=True)
class Lattice:
    """R^3 vertices on the corners of the cube; the field's grids, its snapshot and the mesh volume use it."""

    resolution: int
    bound: float = CUBE_BOUND

    @property
    def spacing(self) -> float:
        """Distance between neighbouring vertices [m]."""
        return 2 * self.bound / (self.resolution - 1)

    def axis(self, device=None) -> torch.Tensor:
        """The R vertex coordinates along one axis, from -bound to bound."""
        return torch.linspace(-self.bound, self.bound, self.resolution, device=device)

    def points(self, device=None, z_min: float | None = None) -> torch.Tensor:
        """World positions (N, 3) of the vertices in flat order; with ``z_min`` only the z-layers from the
        last one below ``z_min`` upwards (a contiguous tail of the flat order, ``first_layer(z_min)`` on)."""
        every = slice(0, self.resolution)
        return self.block_points((every, every, slice(self.first_layer(z_min) if z_min is not None else 0, self.resolution)),
                                 device)

    def block(self, low: torch.Tensor, high: torch.Tensor) -> tuple[slice, slice, slice]:
        """The index ranges (x, y, z) of the vertices in the world box [low, high] (corners (3,)); empty ranges when
        the box holds none."""
        axis = self.axis().double()
        first = torch.searchsorted(axis, low.double(), right=False)
        last = torch.searchsorted(axis, high.double(), right=True)
        return tuple(slice(int(a), max(int(a), int(b))) for a, b in zip(first, last))

    def block_points(self, block: tuple[slice, slice, slice], device=None) -> torch.Tensor:
        """World positions (N, 3) of the vertices of a ``block``, in flat order (z slowest, x fastest)."""
        axis = self.axis(device)
        z, y, x = torch.meshgrid(axis[block[2]], axis[block[1]], axis[block[0]], indexing="ij")
        return torch.stack([x, y, z], dim=-1).reshape(-1, 3)

    def first_layer(self, z_min: float) -> int:
        """Index of the lowest z-layer kept by ``points(z_min=...)``: one layer below ``z_min`` is kept, so
        the cells that straddle ``z_min`` are whole."""
        return int(np.count_nonzero(self.axis().numpy() < z_min - self.spacing))

    def normalise(self, x: torch.Tensor) -> torch.Tensor:
        """World coordinates -> [-1, 1]^3 (the vertex coordinates of ``grid_sample``)."""
        return x / self.bound

    def vertex_units(self, x: torch.Tensor) -> torch.Tensor:
        """World coordinates -> vertex units: vertex i of an axis sits at i."""
        return (x / self.bound + 1.0) * (0.5 * (self.resolution - 1))

    def nearest_index(self, points: torch.Tensor) -> torch.Tensor:
        """Flat index of the vertex nearest to each point (..., 3); points outside snap to the boundary."""
        return self._flat_nearest(self.vertex_units(points))

    def nearest_index_on_rays(self, origins: torch.Tensor, dirs: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """``nearest_index`` of the samples origins + t dirs (R, S) of rays (R, 3), computed in vertex units
        from the start (one multiply-add per coordinate and sample; it may round a sample lying exactly halfway
        between two vertices to the other one)."""
        h = 0.5 * (self.resolution - 1)
        start, step = (origins / self.bound + 1.0) * h, dirs * (h / self.bound)
        return self._flat_nearest(torch.addcmul(start[:, None, :], t[..., None], step[:, None, :]))

    def _flat_nearest(self, units: torch.Tensor) -> torch.Tensor:
        """Flat index of the vertex nearest to points in vertex units (..., 3) (rounded in place)."""
        return flat_index_of_whole_floats(units.round_().clamp_(0, self.resolution - 1), self.resolution)

    def dilated(self, vertices: torch.Tensor) -> torch.Tensor:
        """A boolean vertex mask (R^3,) in flat order, grown by one vertex along every axis and diagonal (the 3x3x3
        neighbourhood of each marked vertex)."""
        r = self.resolution
        grown = torch.nn.functional.max_pool3d(vertices.view(1, 1, r, r, r).float(), 3, stride=1, padding=1)
        return grown.view(-1) > 0

    def nearest_layer(self, z: torch.Tensor) -> torch.Tensor:
        """Index of the z-layer nearest to each height z (the same rounding as ``nearest_index``)."""
        r = self.resolution
        return self.vertex_units(z).round().long().clamp(0, r - 1)


@dataclass(frozen=True)
class VoxelGrid:
    """R^3 cells filling the cube; the explicit map's voxels."""

    resolution: int
    bound: float = CUBE_BOUND

    @property
    def voxel(self) -> float:
        """Edge length of a cell [m]."""
        return 2 * self.bound / self.resolution

    def to_voxel_units(self, x: torch.Tensor) -> torch.Tensor:
        """World coordinates -> voxel units: cell (i, j, k) is [i, i+1) x [j, j+1) x [k, k+1)."""
        return (x + self.bound) / self.voxel

    def cell_index(self, points: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Flat index of the cell holding each point (..., 3), and whether the point lies in the grid."""
        return self.flat_from_voxel_units(self.to_voxel_units(points))

    def flat_from_voxel_units(self, u: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Flat index of the cell at voxel coordinates u (..., 3) (clamped to the grid) and whether u lies inside."""
        r = self.resolution
        ijk = torch.floor(u).long()
        inside = ((ijk >= 0) & (ijk < r)).all(dim=-1)
        ijk = ijk.clamp(0, r - 1)
        return flat_index(ijk[..., 0], ijk[..., 1], ijk[..., 2], r), inside

    def first_centre(self) -> float:
        """World coordinate of the first cell centre along each axis."""
        return -self.bound + self.voxel / 2
