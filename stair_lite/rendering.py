"""Occupancy volume rendering (paper Sec. III-B, Eqs. 2-5, following UNISURF).

Introduced in notebook 02 (colour and depth) and notebook 03 (semantics, target-only renders).
Along a ray with samples x_1..x_N: T_i = prod_{j<i} (1 - o_j), w_i = o_i T_i, and
C = sum w_i c_i, D = sum w_i d_i, S = sum w_i s_i. What the ray does not hit (1 - sum w_i) is
composited as white colour, depth 0 and the background class, matching the measurements.
"""
from __future__ import annotations

from collections.abc import Iterator
from functools import cached_property

import numpy as np
import torch

from .classes import BACKGROUND, NUM_CLASSES
from .config import RenderConfig
from .field import class_probabilities
from .geometry import Intrinsics, pixel_rays
from .lattice import Lattice, flat_index_of_whole_floats


def ray_box_intersection(origins: torch.Tensor, dirs: torch.Tensor, bound, near: float, low=None):
    """Entry and exit ray parameters of the cube [-bound, bound]^3 (slab method), or of the box [low, bound] when
    ``low`` is given (both (3,) tensors then); entry clamped to >= near.

    Returns (t_near, t_far, hit) with hit False where the ray misses the box.
    """
    safe = torch.where(dirs.abs() < 1e-12, torch.full_like(dirs, 1e-12), dirs)
    t0, t1 = ((-bound if low is None else low) - origins) / safe, (bound - origins) / safe
    t_near = torch.minimum(t0, t1).amax(dim=1).clamp(min=near)
    t_far = torch.maximum(t0, t1).amin(dim=1)
    return t_near, t_far, t_far > t_near


def reached_vertices(lattice: Lattice, origins: torch.Tensor, dirs: torch.Tensor, depth: torch.Tensor, near: float,
                     rays_per_chunk: int = 16384, rays_per_part: int = 2048) -> torch.Tensor:
    """Which lattice vertices (a boolean mask in flat order) belong to a cell the rays pass through in front of their
    measured depth (the whole way through the cube for a ray that hit nothing, depth 0), their surface points'
    cells included: where the measurements say something. Points every half vertex spacing along each ray mark
    their cells (``n`` points per ray, from the longest ray of its chunk of ``rays_per_chunk``); a vertex is reached
    when one of its 8 cells is. The points are made ``rays_per_part`` rays at a time (the same points: a part's rays
    keep their chunk's ``n``): a chunk's side-view rays hold up to about 7e6 points, 0.5 GB of working arrays at once."""
    r = lattice.resolution
    t_near, t_far, hit = ray_box_intersection(origins, dirs, lattice.bound, near)
    t_end = torch.where(depth > 0, torch.minimum(t_far, depth), t_far)
    rows = torch.nonzero(hit & (t_end >= t_near)).squeeze(1)
    cells = torch.zeros((r - 1) ** 3, dtype=torch.bool, device=origins.device)
    for chunk in torch.split(rows, rays_per_chunk):
        n = int(torch.ceil((t_end[chunk] - t_near[chunk]).max() / (0.5 * lattice.spacing))) + 1
        steps = torch.linspace(0.0, 1.0, n, device=origins.device)
        for part in torch.split(chunk, rays_per_part):
            t = t_near[part, None] + (t_end[part] - t_near[part])[:, None] * steps
            points = origins[part, None, :] + t[..., None] * dirs[part, None, :]
            cell = lattice.vertex_units(points.reshape(-1, 3)).floor_().clamp_(0, r - 2)
            cells[flat_index_of_whole_floats(cell, r - 1)] = True
    # a vertex is reached when any of the (up to) 8 cells around it is: a 2x2x2 max over the zero-padded cell grid
    padded = torch.nn.functional.pad(cells.view(1, 1, r - 1, r - 1, r - 1).float(), (1, 1, 1, 1, 1, 1))
    return (torch.nn.functional.max_pool3d(padded, kernel_size=2, stride=1) > 0).reshape(-1)


def sample_along_rays(
    t_near: torch.Tensor,
    t_far: torch.Tensor,
    n_samples: int,
    generator: torch.Generator | None = None,
    depth: torch.Tensor | None = None,
    n_surface: int = 0,
    band: float = 0.08,
) -> torch.Tensor:
    """Sorted sample parameters t (R, S) per ray.

    ``n_samples`` uniform strata fill [t_near, t_far]: at their centres, or jittered within each
    stratum when a ``generator`` is given (training). With ``depth`` and ``n_surface`` > 0, another
    ``n_surface`` strata fill [depth - band, depth + band] on rays that hit something (depth > 0),
    so training sees the surface finely; on other rays they are spread uniformly like the rest.
    """
    r = t_near.shape[0]
    device = t_near.device

    def strata(lo, hi, n):
        offsets = (
            torch.rand(r, n, generator=generator, device=device) if generator is not None else torch.full((r, n), 0.5, device=device)
        )
        return lo[:, None] + (hi - lo)[:, None] * (torch.arange(n, device=device) + offsets) / n

    t = strata(t_near, t_far, n_samples)
    if depth is not None and n_surface > 0:
        hit = depth > 0
        lo = torch.where(hit, (depth - band).clamp(min=0.0), t_near).maximum(t_near)
        hi = torch.where(hit, depth + band, t_far).minimum(t_far)
        hi = torch.maximum(hi, lo)
        t = torch.sort(torch.cat([t, strata(lo, hi, n_surface)], dim=1), dim=1).values
    return t


def window_indices(t_near: torch.Tensor, t_far: torch.Tensor, n_samples: int, b_near: torch.Tensor, b_far: torch.Tensor,
                   crosses: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Per ray, the window [first, last) of the indices of its unjittered samples (strata centres of [t_near, t_far])
    that can lie in the ray-parameter interval [b_near, b_far], with one sample of margin at either end against
    rounding; an empty window where the ray does not ``crosses`` the interval."""
    length = (t_far - t_near).clamp(min=1e-12)
    first = (torch.floor((b_near - t_near) / length * n_samples - 0.5) - 1).clamp(0, n_samples).long()
    last = (torch.ceil((b_far - t_near) / length * n_samples - 0.5) + 2).clamp(0, n_samples).long()
    return first, torch.where(crosses, torch.maximum(last, first), first)


def strata_centres(t_near: torch.Tensor, t_far: torch.Tensor, index: torch.Tensor, n_samples: int) -> torch.Tensor:
    """The parameter t of sample ``index`` of ``n_samples`` unjittered samples of [t_near, t_far] (broadcasting), in
    the same floats as ``sample_along_rays`` computes it."""
    return t_near + (t_far - t_near) * (index.to(t_near.dtype) + 0.5) / n_samples


def compositing_weights(occ: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Eq. 5: transmittance T_i = prod_{j<i} (1 - o_j) and weights w_i = o_i T_i, for occ (R, S)."""
    transmittance = torch.cumprod(torch.cat([torch.ones_like(occ[:, :1]), 1.0 - occ[:, :-1]], dim=1), dim=1)
    return occ * transmittance, transmittance


class SkipGrid:
    """Empty-space skipping: which vertices of a ``Lattice`` over the cube may be occupied.

    Built from the field itself (``build_skip_grid``); samples whose nearest vertex is not kept are
    treated as empty (o = 0) without evaluating the field. Dilation by one cell keeps it conservative,
    and a test compares skipped renders with exact ones.
    """

    def __init__(self, keep: torch.Tensor, lattice: Lattice):
        self.keep = keep.reshape(-1)  # (R^3,) bool, in the lattice's flat order
        self.lattice = lattice

    def lookup(self, points: torch.Tensor) -> torch.Tensor:
        """Whether each point (..., 3) lies in a kept cell (nearest lattice vertex)."""
        index = self.lattice.nearest_index(points)
        return self.keep.index_select(0, index.reshape(-1)).view(index.shape)  # (index_select: faster than indexing)

    @cached_property
    def box(self) -> tuple[torch.Tensor, torch.Tensor] | None:
        """A world box (low, high corners) outside which ``lookup`` keeps no point: the kept vertices' bounding box,
        grown by one vertex spacing (a point belongs to its nearest vertex, half a spacing away at most; the other
        half is a margin for rounding). None when no vertex is kept. Computed once (a grid's cells do not change)."""
        rows = self.keep.nonzero().squeeze(1)
        if len(rows) == 0:
            return None
        r, axis = self.lattice.resolution, self.lattice.axis(self.keep.device)
        ijk = torch.stack([rows % r, (rows // r) % r, rows // (r * r)], dim=1)
        return axis[ijk.amin(dim=0)] - self.lattice.spacing, axis[ijk.amax(dim=0)] + self.lattice.spacing

    @cached_property
    def _kept_cell_corners(self) -> torch.Tensor:
        """The 8 corners (K, 8, 3) of each kept vertex's cell (the cube of one spacing around it, grown by 2 % against
        rounding), in float64; computed once, for every view's ``ray_windows``."""
        rows = self.keep.nonzero().squeeze(1)
        r, axis = self.lattice.resolution, self.lattice.axis(self.keep.device).double()
        centres = torch.stack([axis[rows % r], axis[(rows // r) % r], axis[rows // (r * r)]], dim=1)
        signs = torch.tensor([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=torch.float64,
                             device=self.keep.device)
        return centres[:, None, :] + 0.51 * self.lattice.spacing * signs

    def ray_windows(self, intrinsics: Intrinsics, pose: np.ndarray, depth_bins: int = 16
                    ) -> tuple[torch.Tensor, torch.Tensor] | None:
        """Per pixel of a pinhole view at ``pose``, an interval [t_lo, t_hi] (two (H*W,) tensors; inf and -inf where
        no kept cell is seen) of the parameter t of its ray (``pixel_rays``: t is the camera depth) outside which the
        ray meets no kept cell. A point is in a kept cell when its nearest vertex is kept, so the cell is the cube of
        one spacing around the vertex (grown by 2 % against rounding); a cube's image lies in the box of its corners'
        images and its depths between its corners' (depth is linear), so it covers only the pixels whose centre lies in
        that box, at those depths. The kept cells' depths are cut into ``depth_bins`` equal bins, each bin's covered
        pixels painted at once, and a pixel's interval runs from its first painted bin to its last (with one bin, the
        pixels with an interval are the kept cells' image footprint). None when a kept cell reaches behind the camera."""
        h, w = intrinsics.height, intrinsics.width
        corners, device = self._kept_cell_corners, self.keep.device
        if len(corners) == 0:
            return torch.full((h * w,), torch.inf, device=device), torch.full((h * w,), -torch.inf, device=device)
        pose = torch.as_tensor(pose, dtype=torch.float64, device=device)
        camera = (corners - pose[:3, 3]) @ pose[:3, :3]  # R^T (p - t), (K, 8, 3)
        depth = camera[..., 2]
        if depth.min() <= 1e-6:
            return None
        u = intrinsics.fx * camera[..., 0] / depth + intrinsics.cx
        v = intrinsics.fy * camera[..., 1] / depth + intrinsics.cy
        # pixel i's centre lies at i + 0.5: the columns i with u_min <= i + 0.5 <= u_max, clipped to the image
        first_col, last_col = torch.ceil(u.amin(1) - 0.5).clamp(0, w), torch.floor(u.amax(1) - 0.5).clamp(-1, w - 1)
        first_row, last_row = torch.ceil(v.amin(1) - 0.5).clamp(0, h), torch.floor(v.amax(1) - 0.5).clamp(-1, h - 1)
        near, far = depth.amin(1), depth.amax(1)
        lowest, width = near.min(), (far.max() - near.min()).clamp(min=1e-9) / depth_bins
        first_bin = ((near - lowest) / width).floor().clamp(0, depth_bins - 1).long()
        last_bin = ((far - lowest) / width).floor().clamp(0, depth_bins - 1).long()
        # a cell spans the bins first_bin..last_bin: one box per cell and bin
        some = (first_col <= last_col) & (first_row <= last_row)
        spans = (last_bin - first_bin + 1) * some
        cell = torch.repeat_interleave(torch.arange(len(spans), device=device), spans)
        bins = first_bin[cell] + torch.arange(len(cell), device=device) - (torch.cumsum(spans, 0) - spans)[cell]
        c0, c1, r0, r1 = (x[cell].long() for x in (first_col, last_col, first_row, last_row))
        t_lo = torch.full((h, w), torch.inf, device=device)
        t_hi = torch.full((h, w), -torch.inf, device=device)
        if len(cell) == 0:
            return t_lo.view(-1), t_hi.view(-1)
        # every box painted at once, in the image region the boxes cover: +1 at its corner, -1 past its right and lower
        # edges, +1 past both; a 2-D cumsum
        top, left, bottom, right = int(r0.min()), int(c0.min()), int(r1.max()) + 1, int(c1.max()) + 1
        marks = torch.zeros(depth_bins, bottom - top + 1, right - left + 1, dtype=torch.int32, device=device)
        for rr, cc, sign in ((r0, c0, 1), (r0, c1 + 1, -1), (r1 + 1, c0, -1), (r1 + 1, c1 + 1, 1)):
            marks.index_put_((bins, rr - top, cc - left), torch.full_like(rr, sign, dtype=torch.int32), accumulate=True)
        painted = marks.cumsum(1).cumsum(2)[:, :-1, :-1] > 0  # (bins, rows, columns of the region)
        first = torch.full(painted.shape[1:], depth_bins, device=device)  # each pixel's first and last painted bin
        last = torch.full(painted.shape[1:], -1, device=device)
        for b in range(depth_bins):
            first.masked_fill_(painted[depth_bins - 1 - b], depth_bins - 1 - b)
            last.masked_fill_(painted[b], b)
        seen = last >= 0
        edges = lowest + width * torch.arange(depth_bins + 2, device=device, dtype=torch.float64)
        t_lo[top:bottom, left:right] = torch.where(seen, edges[first], torch.inf).float()
        t_hi[top:bottom, left:right] = torch.where(seen, edges[last + 1], -torch.inf).float()
        return t_lo.view(-1), t_hi.view(-1)

    def above(self, z_min: float) -> "SkipGrid":
        """This grid without the vertex layers below height ``z_min``."""
        r = self.lattice.resolution
        layer_kept = (self.lattice.axis(self.keep.device) >= z_min).repeat_interleave(r * r)
        return SkipGrid(self.keep & layer_kept, self.lattice)


@torch.no_grad()
def build_skip_grid(field, targets: tuple[int, ...] | None = None, threshold: float = 1e-3,
                    also_keep: torch.Tensor | None = None) -> SkipGrid:
    """Mark the field's lattice vertices with occupancy above ``threshold`` (and, with ``targets``, a
    target class as semantic argmax), dilated by one vertex so that no occupied space is skipped.
    ``also_keep`` (R^3,) marks further vertices to keep whatever the field says there (training keeps
    the measured surfaces, so that the field can learn a surface where it believes space is empty)."""
    lattice = field.lattice
    q = field.query(lattice.points(field.device))
    occupied = q["occ"] > threshold
    keep = lattice.dilated(occupied if also_keep is None else occupied | also_keep)
    if targets is not None:
        keep &= lattice.dilated(torch.isin(q["sem"].argmax(dim=1), torch.as_tensor(targets, device=field.device)))
    return SkipGrid(keep, lattice)


def sample_field(field, origins: torch.Tensor, dirs: torch.Tensor, cfg: RenderConfig, n_samples: int | None = None,
                 generator: torch.Generator | None = None, depth: torch.Tensor | None = None,
                 skip: SkipGrid | None = None, semantics: bool = False) -> dict[str, torch.Tensor]:
    """Samples along rays and the field's occupancy there: parameters t (R, S), points (R, S, 3), occupancy
    (R, S), zero where the field is not evaluated (outside the cube, or in a cell ``skip`` leaves out), the
    flat mask ``evaluate`` of evaluated samples and their ``located`` corners (``SemanticField.locate``).
    With ``semantics``, also the class logits (R, S, P) of the evaluated samples (zero elsewhere) and their
    colour features ``f_rgb``, from one lookup of the appearance grid. With a measured ``depth`` (training), a ray
    that hit something is sampled only up to ``cfg.behind_surface`` behind it."""
    t_near, t_far, hit = ray_box_intersection(origins, dirs, field.lattice.bound, cfg.near)
    if depth is not None and cfg.behind_surface is not None:
        # a measured depth tells what lies in front of the surface and nothing of what lies behind it: a training
        # ray that hit something ends just behind its surface, so it teaches nothing about the volume beyond
        t_far = torch.where(depth > 0, torch.minimum(t_far, depth + cfg.behind_surface), t_far)
    t_far = torch.where(hit & (t_far > t_near), t_far, t_near + 1e-3)
    t = sample_along_rays(
        t_near, t_far, n_samples or cfg.n_samples, generator, depth, cfg.n_surface_samples if depth is not None else 0,
        cfg.surface_band,
    )
    r, s = t.shape
    points = origins[:, None, :] + t[..., None] * dirs[:, None, :]
    evaluate = hit[:, None].expand(r, s)
    if skip is not None:
        evaluate = evaluate & skip.lookup(points)
    evaluate = evaluate.reshape(-1)
    rows = evaluate.nonzero().squeeze(1)  # rows are gathered and placed with index_select / index_copy (fast on a CPU)
    located = field.locate(points.reshape(-1, 3).index_select(0, rows))
    occ = torch.zeros(r * s, device=t.device).index_copy(0, rows, field.occupancy_at(located))
    out = {"t": t, "points": points, "occ": occ.view(r, s), "evaluate": evaluate, "located": located}
    if semantics:
        f_rgb, f_sem = field.appearance_at(located)
        out["sem_logits"] = torch.zeros(r * s, f_sem.shape[1], device=t.device).index_copy(0, rows, f_sem).view(r, s, -1)
        out["f_rgb"] = f_rgb
    return out


def is_target(sem_logits: torch.Tensor, targets: tuple[int, ...]) -> torch.Tensor:
    """Whether each sample's semantic argmax is a target class (the target-only mask of Sec. IV-A)."""
    return torch.isin(sem_logits.argmax(dim=-1), torch.as_tensor(targets, device=sem_logits.device))


def sample_appearance(field, samples: dict[str, torch.Tensor], active: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Colour (K, 3) and class probabilities (K, P) of the K ``active`` samples (a flat mask, a subset of the
    evaluated ones), in flat order: the appearance grid is read at the active samples only (or taken from
    ``samples`` when ``sample_field`` already read it)."""
    rows = active[samples["evaluate"]]  # positions of the active samples among the evaluated ones
    located = samples["located"].subset(rows)
    if "f_rgb" in samples:
        f_rgb, f_sem = samples["f_rgb"][rows], samples["sem_logits"].view(len(active), -1)[active]
    else:
        f_rgb, f_sem = field.appearance_at(located)
    return field.colour_from(f_rgb, located.pe), class_probabilities(f_sem)


def composite(values: torch.Tensor, rows: torch.Tensor, weights: torch.Tensor) -> torch.Tensor:
    """sum_i w_i v_i per ray (Eqs. 2 and 4) over the samples at flat indices ``rows`` of the weights (R, S):
    ``values`` (K, C) of those samples only; every other sample's term is left out (its weight cannot change
    the pixel) -> (R, C)."""
    n_rays, n_samples = weights.shape
    per_ray = torch.zeros(n_rays, values.shape[1], dtype=values.dtype, device=values.device)
    return per_ray.index_add(0, rows // n_samples, weights.reshape(-1).index_select(0, rows)[:, None] * values)


def render_rays(
    field,
    origins: torch.Tensor,
    dirs: torch.Tensor,
    cfg: RenderConfig,
    n_samples: int | None = None,
    targets: tuple[int, ...] | None = None,
    generator: torch.Generator | None = None,
    depth: torch.Tensor | None = None,
    skip: SkipGrid | None = None,
    colour_weight_threshold: float = 1e-5,
) -> dict[str, torch.Tensor]:
    """Render colour (R, 3), depth (R,), semantic probabilities (R, P), accumulated weight (R,) of rays.

    ``targets``: target-only rendering for evaluation: the occupancy of samples whose semantic
    argmax is not a target class is set to zero (paper Sec. IV-A). ``generator``/``depth`` switch on
    training-time jitter and depth-guided samples. ``skip`` leaves out samples in empty space.
    Colour and class probabilities are evaluated only at samples whose weight exceeds
    ``colour_weight_threshold`` (the others cannot change the pixel) and whose occupancy exceeds
    ``cfg.colour_min_occupancy``.
    """
    samples = sample_field(field, origins, dirs, cfg, n_samples, generator, depth, skip, semantics=targets is not None)
    t, occ = samples["t"], samples["occ"]
    if targets is not None:
        occ = occ * is_target(samples["sem_logits"], targets)
    weights, transmittance = compositing_weights(occ)
    acc = weights.sum(dim=1)

    active = ((weights.detach() > colour_weight_threshold) & (occ.detach() > cfg.colour_min_occupancy)).view(-1)
    rows = active.nonzero().squeeze(1)
    rgb, probs = sample_appearance(field, samples, active)
    colour = composite(rgb, rows, weights) + (1.0 - acc)[:, None]
    depth_map = (weights * t).sum(dim=1)
    # Semantic rendering (Eq. 4) uses detached weights, as the reference code does: semantics do not
    # move geometry. Like colour, class probabilities are computed only where the weight matters.
    sem = composite(probs, rows, weights.detach())
    sem = sem + torch.nn.functional.one_hot(torch.tensor(BACKGROUND), NUM_CLASSES).to(sem) * (1.0 - acc.detach())[:, None]
    return {
        "rgb": colour,
        "depth": depth_map,
        "sem": sem,
        "acc": acc,
        "weights": weights,
        "transmittance": transmittance,
        "occ": occ,
        "t": t,
    }


@torch.no_grad()
def render_image(
    field,
    intrinsics: Intrinsics,
    pose: np.ndarray,
    cfg: RenderConfig,
    targets: tuple[int, ...] | None = None,
    n_samples: int | None = None,
    skip: SkipGrid | None = None,
) -> dict[str, np.ndarray]:
    """Render a whole image: rgb (H, W, 3), depth (H, W), labels (H, W) (argmax of S), acc (H, W)."""
    origins, dirs = pixel_rays(intrinsics, pose)
    device = field.device
    origins = torch.as_tensor(origins, dtype=torch.float32, device=device)
    dirs = torch.as_tensor(dirs, dtype=torch.float32, device=device)
    parts = []
    for o, d in zip(torch.split(origins, cfg.chunk_rays), torch.split(dirs, cfg.chunk_rays)):
        out = render_rays(field, o, d, cfg, n_samples=n_samples, targets=targets, skip=skip)
        parts.append({k: out[k] for k in ("rgb", "depth", "sem", "acc")})
    h, w = intrinsics.height, intrinsics.width
    cat = {k: torch.cat([p[k] for p in parts]) for k in parts[0]}
    return {
        "rgb": cat["rgb"].clamp(0, 1).view(h, w, 3).cpu().numpy(),
        "depth": cat["depth"].view(h, w).cpu().numpy(),
        "labels": cat["sem"].argmax(dim=1).view(h, w).cpu().numpy(),
        "sem": cat["sem"].view(h, w, -1).cpu().numpy(),
        "acc": cat["acc"].view(h, w).cpu().numpy(),
    }


def render_target_views(field, intrinsics: Intrinsics, poses: list[np.ndarray], cfg: RenderConfig,
                        targets: tuple[int, ...], skip: SkipGrid | None = None) -> list[np.ndarray]:
    """Target-only colour renders (H, W, 3) of the field at each pose (paper Sec. IV-A); ``skip`` leaves
    out the lattice cells it does not keep."""
    return [render_image(field, intrinsics, p, cfg, targets=targets, skip=skip)["rgb"] for p in poses]


@torch.no_grad()
def render_target_views_and_cut(field, intrinsics: Intrinsics, poses: list[np.ndarray], cfg: RenderConfig,
                                targets: tuple[int, ...], skip: SkipGrid, z_min: float,
                                colour_weight_threshold: float = 1e-5,
                                rays_per_group: int = 2**20) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """``render_target_views`` with ``skip`` and with ``skip.above(z_min)``, from one evaluation of the
    field per sample: the second composite zeroes the samples whose nearest lattice vertex lies below
    ``z_min``, and colour is evaluated once where either composite's weight matters. Only the samples that ``skip``
    keeps are evaluated and composited (a skipped sample has o = 0: its factor 1 - o = 1 leaves every transmittance
    as it is), and only those in each ray's window (``SkipGrid.ray_windows``) are looked up; a ray with no window is
    white in both. A kept sample whose class is not a target has o = 0 in both composites: it is dropped as a
    skipped one, after the appearance read and before its occupancy and gamma(x) are computed. The poses are taken in groups of about ``rays_per_group`` rays. Yields the two images of each pose
    in turn: only one group's images are held at a time (the paper's 100 test views of 400x400 pixels, kept whole,
    would be 384 MB)."""
    group = max(1, rays_per_group // (intrinsics.height * intrinsics.width))
    for start in range(0, len(poses), group):
        yield from zip(*_render_group_and_cut(field, intrinsics, poses[start : start + group], cfg, targets, skip,
                                              z_min, colour_weight_threshold))


def live_rays(skip: SkipGrid, intrinsics: Intrinsics, poses, cfg: RenderConfig):
    """The rays of ``poses`` that can meet a kept cell, as their rows in the group's pixels, origins, directions and
    sample windows [first, last) (``window_indices``) of the ``cfg.n_samples`` unjittered samples across the cube."""
    rows, origins, dirs, t_near, t_far, first, last = [], [], [], [], [], [], []
    for view, pose in enumerate(poses):
        o, d = (torch.as_tensor(a, dtype=torch.float32, device=skip.keep.device) for a in pixel_rays(intrinsics, pose))
        windows = skip.ray_windows(intrinsics, pose)
        if windows is None:  # a kept cell behind the camera: the kept cells' box bounds every ray instead
            if skip.box is None:
                continue
            windows = ray_box_intersection(o, d, skip.box[1], cfg.near, low=skip.box[0])[:2]
        row = (windows[1] >= windows[0]).nonzero().squeeze(1)
        o, d = o[row], d[row]
        near, far, hit = ray_box_intersection(o, d, skip.lattice.bound, cfg.near)
        far = torch.where(hit & (far > near), far, near + 1e-3)
        a, b = window_indices(near, far, cfg.n_samples, windows[0][row], windows[1][row], hit)
        for parts, value in zip((rows, origins, dirs, t_near, t_far, first, last),
                                (row + view * len(windows[0]), o, d, near, far, a, b)):
            parts.append(value)
    return [torch.cat(parts) if parts else torch.zeros(0, dtype=torch.long) for parts in
            (rows, origins, dirs, t_near, t_far, first, last)]


def kept_window_samples(skip: SkipGrid, origins, dirs, t_near, t_far, first, last, n_samples: int):
    """The samples of each ray's window [first, last) (``window_indices``, rays as ``live_rays`` gives them) that lie
    in a kept cell: their ray (an index into the rays given, ascending, each ray's samples in order along it) and
    their points (K, 3), at the parameters ``strata_centres`` gives (the floats of ``sample_along_rays``)."""
    counts = last - first
    ray = torch.repeat_interleave(torch.arange(len(counts), device=origins.device), counts)
    # a sample's index along its ray: its place in the flat list, shifted by its ray's offset (rows are gathered with
    # index_select, on a CPU about twice as fast as indexing with a tensor for the same rows)
    index = (first - (torch.cumsum(counts, 0) - counts)).index_select(0, ray) + torch.arange(len(ray), device=origins.device)
    t = strata_centres(t_near.index_select(0, ray), t_far.index_select(0, ray), index, n_samples)
    points = origins.index_select(0, ray) + t[:, None] * dirs.index_select(0, ray)
    kept = skip.lookup(points).nonzero().squeeze(1)
    return ray.index_select(0, kept), points.index_select(0, kept)


def kept_compositing(ray: torch.Tensor, n_rays: int, *occupancies: torch.Tensor):
    """Eq. 5 over flat samples (``ray``: each sample's ray, ascending, each ray's samples in order along it, as
    ``kept_window_samples`` gives them). The samples of each ray are set side by side in a row, padded with o = 0 (a
    factor 1 - o = 1). Returns the samples' places in those rows, flat (ray x width + slot), and for each occupancy
    (K,) of the samples its weights and transmittance (n_rays, width): ``w.view(-1).index_select(0, places)`` gives
    the samples' own."""
    per_ray = torch.bincount(ray, minlength=n_rays)
    width = int(per_ray.max()) if len(ray) else 0
    places = torch.arange(len(ray), device=ray.device) + (ray * width - (torch.cumsum(per_ray, 0) - per_ray).index_select(0, ray))
    dense = [torch.zeros(n_rays * width, device=occ.device).index_copy_(0, places, occ).view(n_rays, width)
             for occ in occupancies]
    return places, [compositing_weights(d) for d in dense]


def _render_group_and_cut(field, intrinsics, poses, cfg, targets, skip, z_min, colour_weight_threshold):
    lattice, h, w = skip.lattice, intrinsics.height, intrinsics.width
    images = torch.ones(2, len(poses) * h * w, 3, device=field.device)  # the full and the cut composite of every ray
    rows, *rays = live_rays(skip, intrinsics, poses, cfg)
    # consecutive rays in chunks of about chunk_rays x n_samples window samples (RenderConfig.chunk_rays's memory bound)
    counts = rays[-1] - rays[-2]
    sizes = torch.bincount((torch.cumsum(counts, 0) - counts) // (cfg.chunk_rays * cfg.n_samples)).tolist() \
        if len(rows) else []
    for chunk in (slice(a - n, a) for a, n in zip(np.cumsum(sizes), sizes) if n):
        n_rays = chunk.stop - chunk.start
        ray, points = kept_window_samples(skip, *(x[chunk] for x in rays), cfg.n_samples)
        located = field.locate(points)
        f_rgb, f_sem = field.appearance_at(located)
        # a sample of another class has o = 0 in both composites: dropped like a skipped one, before its occupancy
        target = is_target(f_sem, targets).nonzero().squeeze(1)
        ray, points, f_rgb = (x.index_select(0, target) for x in (ray, points, f_rgb))
        located = located.subset(target)
        occ = field.occupancy_at(located)
        above = lattice.axis(occ.device)[lattice.nearest_layer(points[:, 2])] >= z_min
        places, composites = kept_compositing(ray, n_rays, occ, occ * above)
        weights = [in_rows.view(-1).index_select(0, places) for in_rows, _ in composites]
        active = (((weights[0] > colour_weight_threshold) | (weights[1] > colour_weight_threshold))
                  & (occ > cfg.colour_min_occupancy)).nonzero().squeeze(1)
        rgb = field.colour_from(f_rgb.index_select(0, active), located.pe.index_select(0, active))
        active_ray = ray.index_select(0, active)
        for image, wt in zip(images, weights):
            composited = torch.zeros(n_rays, 3, device=field.device).index_add_(0, active_ray,
                                                                               wt.index_select(0, active)[:, None] * rgb)
            acc = torch.zeros(n_rays, device=field.device).index_add_(0, ray, wt)
            image.index_copy_(0, rows[chunk], composited + (1.0 - acc)[:, None])
    return [list(image.clamp(0, 1).view(len(poses), h, w, 3).cpu().numpy()) for image in images]
