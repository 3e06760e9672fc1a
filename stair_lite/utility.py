"""The semantic-targeted utility of a candidate view (paper Sec. III-C, Eqs. 10-15).

Introduced in notebook 04. For a view's rays with samples x_i:
  H_pt(x)  = -o ln o - (1 - o) ln(1 - o)                          (Eq. 10, nats)
  H_ray(r) = sum_i T(x_i) H_pt(x_i)                               (Eq. 11, transmittance-weighted)
  U_er(v)  = sum_rays H_ray                                        (Eq. 12, exploration)
  U_et(v)  = sum_rays H_ray * [argmax S(r) in targets]             (Eqs. 13-14, exploitation; Eq. 14 is the mask)
  U(v)     = U_et(v) + epsilon * U_er(v)                           (Eq. 15)

Beyond the paper (notebook 07), for labels that can be wrong, two options read the same render:
  p_T(r)    = sum_{c in targets} S_c(r)                            (the rendered probability of a target)
  soft mask:  U_et(v) = sum_rays H_ray * p_T(r)                    (instead of the argmax test of Eq. 14)
  H_sem(r)  = -sum_c S_c(r) ln S_c(r)                              (entropy of the rendered class distribution)
  U_sem(v)  = sum_rays H_sem(r);  U(v) = U_et + epsilon U_er + lambda U_sem

Candidate views are rendered from a ``FieldSnapshot``: the field's occupancy, point entropy and
class probabilities evaluated once per planning step on a lattice, then read by nearest-vertex
lookup along every candidate ray, instead of running the MLPs at every sample (notebook 04
measures how often this changes the chosen view against the exact computation).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F

from .classes import BACKGROUND, NUM_CLASSES
from .config import PlanConfig, check_epsilon
from .field import trilinear
from .geometry import Intrinsics, pixel_rays, view_to_pose
from .lattice import Lattice
from .rendering import compositing_weights, ray_box_intersection, sample_along_rays

def point_entropy(occ: torch.Tensor) -> torch.Tensor:
    """Eq. 10: Bernoulli entropy of the occupancy, in nats. ``xlogy`` makes 0 ln 0 = 0, so it is exactly
    0 at o = 0 and o = 1 and never NaN."""
    o = occ.clamp(0.0, 1.0)
    return -(torch.special.xlogy(o, o) + torch.special.xlogy(1.0 - o, 1.0 - o))


@dataclass(frozen=True)
class UtilityOptions:
    """The paper's utility, on a map whose unknown is marked as the presets mark it, by default; the reference code's
    variants as options (see notebook 04).

    ``saturating_rays``: per-ray uncertainty 1 - exp(-H_ray) (bits) instead of H_ray.
    ``delete_background``: samples whose class argmax is background count as empty.
    ``mask_dilation``: grow the target mask by this many pixels (the reference uses 2 at 400 px).
    ``soft_mask``: weigh each ray by its rendered target probability p_T instead of the argmax test.
    ``semantic_weight``: lambda, the weight of the semantic-uncertainty term U_sem (0: the paper's utility).
    ``unknown_occupancy``: in planning renders, the prior occupancy of lattice vertices no measured ray reached (the
    field itself keeps them empty, so metrics and meshes never see it; it takes effect in ``FieldSnapshot.for_planning``);
    0: unknown space carries no entropy.
    ``unknown_target_radius``: unknown vertices within this distance [m] of a target surface render with that
    target's class, so that the unseen side of a target counts as exploitation (0: off).
    ``unknown_within``: mark only the unreached vertices within this distance [m] of the scene's centre, the volume a
    mission must reconstruct (None: the whole scene cube, whose corners reach out among the cameras).
    ``min_ray_opacity``: rays whose accumulated opacity is below this carry no uncertainty (the reference code: 0.01).
    ``min_occupancy``: samples whose occupancy is below this count as empty (the reference code: 0.01, below which it
    computes no class logits and so deletes the sample as background).
    """

    epsilon: float = PlanConfig.epsilon
    saturating_rays: bool = False
    delete_background: bool = False
    mask_dilation: int = 0
    soft_mask: bool = False
    semantic_weight: float = 0.0
    unknown_occupancy: float = PlanConfig.unknown_occupancy
    unknown_target_radius: float = PlanConfig.unknown_target_radius
    unknown_within: float | None = None
    min_ray_opacity: float = 0.0
    min_occupancy: float = 0.0

    @classmethod
    def from_plan(cls, plan: PlanConfig, **overrides) -> "UtilityOptions":
        """A preset's epsilon and marking of the unknown, with ``overrides`` beside (or instead of) them."""
        return cls(**{"epsilon": plan.epsilon, "unknown_occupancy": plan.unknown_occupancy,
                      "unknown_target_radius": plan.unknown_target_radius, **overrides})

    def __post_init__(self):
        check_epsilon(self.epsilon)
        if not np.isfinite(self.semantic_weight) or self.semantic_weight < 0:
            raise ValueError(f"semantic_weight must be a finite number >= 0, got {self.semantic_weight!r}")
        if not 0.0 <= self.unknown_occupancy < 1.0:
            raise ValueError(f"unknown_occupancy must be a probability in [0, 1), got {self.unknown_occupancy!r}")
        if not (np.isfinite(self.unknown_target_radius) and self.unknown_target_radius >= 0):
            raise ValueError(f"unknown_target_radius must be a finite distance >= 0, got {self.unknown_target_radius!r}")
        if self.unknown_within is not None and not (np.isfinite(self.unknown_within) and self.unknown_within > 0):
            raise ValueError(f"unknown_within must be a finite distance > 0 (or None: the whole cube), got "
                             f"{self.unknown_within!r}")
        if not 0.0 <= self.min_occupancy < 1.0:
            raise ValueError(f"min_occupancy must be in [0, 1), got {self.min_occupancy!r}")
        if not 0.0 <= self.min_ray_opacity < 1.0:
            raise ValueError(f"min_ray_opacity must be in [0, 1), got {self.min_ray_opacity!r}")
        if self.mask_dilation < 0:
            raise ValueError(f"mask_dilation must be >= 0 pixels, got {self.mask_dilation!r}")


class FieldSnapshot:
    """The field frozen for one planning step: occupancy, point entropy and class probabilities at the
    vertices of a ``Lattice`` of ``resolution``^3 (the field's own by default), in the lattice's flat
    order. ``lookup`` reads the nearest vertex, or interpolates trilinearly with ``trilinear=True``
    (closer to the field, about 3x slower)."""

    def __init__(self, field, resolution: int | None = None, trilinear: bool = False, unknown_occupancy: float = 0.0,
                 unknown_targets: tuple[tuple[int, ...], float] | None = None, unknown_within: float | None = None,
                 novelty: torch.Tensor | None = None, normals: bool = False):
        self.lattice = Lattice(resolution or field.lattice.resolution, field.lattice.bound)
        self.device, self.trilinear = field.device, trilinear
        points = self.lattice.points(field.device)
        q = field.query(points)
        occ, sem = q["occ"], q["sem"]
        if (unknown_occupancy > 0 or unknown_targets) and field.cfg.reached_only:
            if self.lattice.resolution != field.lattice.resolution:
                raise ValueError("a snapshot that marks the unknown needs the field's own lattice resolution")
            unknown = ~field.reached
            if unknown_within is not None:  # only the volume to reconstruct: a ball about the scene's centre
                unknown &= points.norm(dim=1) <= unknown_within
            occ = torch.where(unknown, torch.full_like(occ, unknown_occupancy), occ)
            if unknown_targets:
                sem = _unknown_near_targets_as_targets(self.lattice, occ, sem, unknown, *unknown_targets)
        # one table per vertex: occupancy, entropy, class probabilities (and a novelty per vertex, for the coverage and
        # Fisher utilities: how little the surface there has been observed)
        columns = [occ[:, None], point_entropy(occ)[:, None], sem] + ([novelty[:, None]] if novelty is not None else [])
        if normals:  # the surface normal at each vertex: minus the occupancy's gradient, normalised (0 where it is flat)
            r = self.lattice.resolution
            grad = torch.stack(torch.gradient(occ.view(r, r, r)), dim=-1).reshape(-1, 3).flip(-1)  # (z, y, x) -> xyz
            length = grad.norm(dim=1, keepdim=True)
            columns.append(torch.where(length > 1e-6, -grad / length.clamp_min(1e-6), torch.zeros_like(grad)))
        self.table = torch.cat(columns, dim=1)

    @classmethod
    def for_planning(cls, field, options: "UtilityOptions", targets: tuple[int, ...], novelty: torch.Tensor | None = None,
                     normals: bool = False) -> "FieldSnapshot":
        """The snapshot a planner with ``options`` reads (the unknown marked as the options say; ``novelty`` and
        ``normals`` for the coverage and Fisher utilities)."""
        near = (tuple(targets), options.unknown_target_radius) if options.unknown_target_radius > 0 else None
        return cls(field, unknown_occupancy=options.unknown_occupancy, unknown_targets=near,
                   unknown_within=options.unknown_within, novelty=novelty, normals=normals)

    def lookup(self, points: torch.Tensor) -> torch.Tensor:
        """(..., 2 + P) values at each point: of the nearest lattice vertex, or trilinearly interpolated."""
        if self.trilinear:
            flat = trilinear(self.table, self.lattice.resolution, self.lattice.normalise(points.reshape(-1, 3)))
            return flat.view(*points.shape[:-1], -1)
        return self._rows(self.lattice.nearest_index(points))

    def lookup_on_rays(self, origins: torch.Tensor, dirs: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """``lookup`` at the samples origins + t dirs (R, S) of rays (R, 3): (R, S, 2 + P)."""
        if self.trilinear:
            return self.lookup(origins[:, None, :] + t[..., None] * dirs[:, None, :])
        return self._rows(self.lattice.nearest_index_on_rays(origins, dirs, t))

    def _rows(self, index: torch.Tensor) -> torch.Tensor:
        return self.table.index_select(0, index.reshape(-1)).view(*index.shape, -1)


def _unknown_near_targets_as_targets(lattice: Lattice, occ: torch.Tensor, sem: torch.Tensor, unknown: torch.Tensor,
                                     targets: tuple[int, ...], radius: float) -> torch.Tensor:
    """Class probabilities where unknown vertices within ``radius`` of a target surface vertex (occupied, a target
    class by argmax) take the class of the nearest such vertex: the unseen part of a target may continue there.
    ``sem`` is changed in place (only those rows are written; no table of all vertices is built) and returned."""
    from scipy.ndimage import distance_transform_edt

    r = lattice.resolution
    labels = sem.argmax(dim=1)
    surface = (occ > 0.5) & torch.isin(labels, torch.as_tensor(targets, device=sem.device)) & ~unknown
    if not bool(surface.any()):
        return sem
    distance, nearest = distance_transform_edt(~surface.view(r, r, r).cpu().numpy(), return_indices=True)
    within = torch.as_tensor(distance.reshape(-1) * lattice.spacing <= radius, device=sem.device)
    near = (within & unknown).nonzero().squeeze(1)
    rows = near.cpu().numpy()  # the nearest surface vertex of each: its flat index
    source = np.ravel_multi_index(tuple(axis.reshape(-1)[rows] for axis in nearest), (r, r, r))
    sem[near] = F.one_hot(labels[torch.as_tensor(source, device=sem.device)], sem.shape[1]).to(sem.dtype)
    return sem


def exact_samples(field, points: torch.Tensor) -> torch.Tensor:
    """The same (..., 2 + P) values computed exactly by the field at each point (no snapshot)."""
    q = field.query(points.reshape(-1, 3))
    values = torch.cat([q["occ"][:, None], point_entropy(q["occ"])[:, None], q["sem"]], dim=1)
    return values.view(*points.shape[:-1], -1)


def _samples_on_rays(source, intrinsics: Intrinsics, poses: list[np.ndarray], n_samples: int,
                     near: float) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The snapshot's (or the exact field's) values at ``n_samples`` samples inside the cube along every pixel ray of
    every pose, (rays, samples, columns), which rays meet the cube, and the rays' directions."""
    device, bound = source.device, source.lattice.bound
    rays = [pixel_rays(intrinsics, p) for p in poses]
    origins = torch.as_tensor(np.concatenate([o for o, _ in rays]), dtype=torch.float32, device=device)
    dirs = torch.as_tensor(np.concatenate([d for _, d in rays]), dtype=torch.float32, device=device)
    t_near, t_far, hit = ray_box_intersection(origins, dirs, bound, near)
    t = sample_along_rays(t_near, torch.where(hit, t_far, t_near + 1e-3), n_samples)
    if isinstance(source, FieldSnapshot):
        return source.lookup_on_rays(origins, dirs, t), hit, dirs
    return exact_samples(source, origins[:, None, :] + t[..., None] * dirs[:, None, :]), hit, dirs


@torch.no_grad()
def render_novel_target_surface(source: "FieldSnapshot", intrinsics: Intrinsics, poses: list[np.ndarray], n_samples: int,
                                targets: tuple[int, ...], power: int = 1, near: float = 0.2) -> torch.Tensor:
    """Per ray (V, H, W): sum_i w_i^power p_T(x_i) nu(x_i), the expected target surface a ray would see, weighted by
    the snapshot's novelty column nu (``FieldSnapshot(novelty=...)``): how little that surface has been observed."""
    values, hit, dirs = _samples_on_rays(source, intrinsics, poses, n_samples, near)
    occ = values[..., 0] * hit[:, None]
    weights, _ = compositing_weights(occ)
    p_target = values[..., [2 + t for t in targets]].sum(dim=-1)
    per_sample = weights**power * p_target * values[..., 2 + NUM_CLASSES]
    if values.shape[-1] > 3 + NUM_CLASSES:  # surface normals: a surface seen head-on is measured best (|cos| of incidence)
        per_sample = per_sample * (values[..., 3 + NUM_CLASSES : 6 + NUM_CLASSES] * dirs[:, None, :]).sum(dim=-1).abs()
    per_ray = per_sample.sum(dim=1)
    return per_ray.view(len(poses), intrinsics.height, intrinsics.width)


@torch.no_grad()
def render_uncertainty(
    source,
    intrinsics: Intrinsics,
    poses: list[np.ndarray],
    n_samples: int,
    near: float = 0.2,
    delete_background: bool = False,
    min_ray_opacity: float = 0.0,
    min_occupancy: float = 0.0,
) -> dict[str, torch.Tensor]:
    """Render, for each pose, per-ray entropy H_ray (V, H, W), class probabilities S (V, H, W, P) and the
    entropy of S, H_sem (V, H, W).

    ``source`` is a FieldSnapshot (fast) or a SemanticField (exact: the field runs at every sample).
    """
    values, hit, _ = _samples_on_rays(source, intrinsics, poses, n_samples, near)
    occ, entropy, probs = values[..., 0] * hit[:, None], values[..., 1] * hit[:, None], values[..., 2 : 2 + NUM_CLASSES]
    if delete_background or min_occupancy > 0:
        empty = (probs.argmax(dim=-1) == BACKGROUND) if delete_background else torch.zeros_like(occ, dtype=torch.bool)
        empty |= occ < min_occupancy
        occ, entropy = occ.masked_fill(empty, 0.0), entropy.masked_fill(empty, 0.0)
    weights, transmittance = compositing_weights(occ)
    h_ray = (transmittance * entropy).sum(dim=1)  # Eq. 11
    acc = weights.sum(dim=1)  # the ray's opacity
    if min_ray_opacity > 0:
        h_ray = h_ray * (acc > min_ray_opacity)
    sem = torch.bmm(weights[:, None, :], probs).squeeze(1)  # sum_i w_i s_i, one small product per ray
    # what the ray does not hit is background: 1 - sum_i w_i, which rounding can make a hair negative on a ray that
    # saturates (o = 0.5 in the marked unknown); clamped, so that a ray through space of no class (uniform class
    # probabilities) ties with the other classes, a tie ``ray_classes`` gives to the background
    sem[:, BACKGROUND] += (1.0 - acc).clamp(min=0.0)
    v, h, w = len(poses), intrinsics.height, intrinsics.width
    return {"h_ray": h_ray.view(v, h, w), "sem": sem.view(v, h, w, NUM_CLASSES), "h_sem": class_entropy(sem).view(v, h, w)}


def class_entropy(sem: torch.Tensor) -> torch.Tensor:
    """H_sem: the entropy [nats] of each class distribution along the last axis (0 ln 0 = 0)."""
    p = sem.clamp(0.0, 1.0)
    return -torch.special.xlogy(p, p).sum(dim=-1)


def target_probability(sem: torch.Tensor, targets: tuple[int, ...]) -> torch.Tensor:
    """p_T(r): the rendered probability that each ray shows a target class (..., H, W)."""
    return sem[..., list(targets)].sum(dim=-1)


# Rendered class probabilities within this of the background's tie with it, and the background wins. A ray through space
# of no class (uniform class probabilities: the marked unknown far from a target) renders every class's equal share, in
# floats whose last bits depend on the CPU's matrix kernel: up to 3e-8 apart on an AMD EPYC (none on an Intel Xeon), and
# a rounding accident must not make the ray a target
CLASS_TIE = 1e-5


def ray_classes(sem: torch.Tensor) -> torch.Tensor:
    """Each ray's rendered class (..., P) -> (...): the argmax of S, a tie with the background (``CLASS_TIE``) going
    to the background."""
    tie = sem.max(dim=-1).values - sem[..., BACKGROUND] <= CLASS_TIE
    return sem.argmax(dim=-1).masked_fill(tie, BACKGROUND)


def target_mask(sem: torch.Tensor, targets: tuple[int, ...], dilation: int = 0) -> torch.Tensor:
    """delta(r) of Eq. 14: rays whose rendered class (``ray_classes``) is a target (V, H, W), optionally dilated."""
    mask = torch.isin(ray_classes(sem), torch.as_tensor(targets, device=sem.device))
    if dilation > 0:
        k = 2 * dilation + 1
        mask = F.max_pool2d(mask[:, None].float(), k, stride=1, padding=dilation)[:, 0] > 0
    return mask


def soft_target_mask(sem: torch.Tensor, targets: tuple[int, ...], dilation: int = 0) -> torch.Tensor:
    """The soft mask: p_T(r) per ray (V, H, W), optionally dilated (the largest p_T within ``dilation`` pixels)."""
    p = target_probability(sem, targets)
    if dilation > 0:
        p = F.max_pool2d(p[:, None], 2 * dilation + 1, stride=1, padding=dilation)[:, 0]
    return p


@dataclass
class Scores:
    """Per-view scores (arrays of length V): exploration U_er, exploitation U_et, semantic uncertainty U_sem
    and utility U."""

    exploration: np.ndarray
    exploitation: np.ndarray
    utility: np.ndarray
    semantic: np.ndarray

    @classmethod
    def concatenate(cls, parts: list["Scores"]) -> "Scores":
        return cls(*(np.concatenate([getattr(p, k) for p in parts]) for k in ("exploration", "exploitation", "utility", "semantic")))

    def columns(self, i: int) -> dict[str, float]:
        """The scores of candidate ``i``, named as a mission record's columns."""
        return {"utility": float(self.utility[i]), "exploitation": float(self.exploitation[i]),
                "exploration": float(self.exploration[i]), "semantic_uncertainty": float(self.semantic[i])}


def poses_in_chunks(views: np.ndarray, intrinsics: Intrinsics, n_samples: int, chunk_samples: int = 2**21):
    """The poses of ``views`` (elevation, azimuth) in lists of whole views of about ``chunk_samples`` samples each: the
    memory of one render, which no score depends on."""
    per_chunk = max(1, chunk_samples // (intrinsics.width * intrinsics.height * n_samples))
    for start in range(0, len(views), per_chunk):
        yield [view_to_pose(el, az) for el, az in views[start : start + per_chunk]]


def score_views(
    source, views: np.ndarray, targets: tuple[int, ...], intrinsics: Intrinsics, n_samples: int,
    options: UtilityOptions = UtilityOptions(), chunk_samples: int = 2**21,
) -> Scores:
    """Eqs. 12-15 for every view (elevation, azimuth) of ``views`` (and U_sem), rendered in chunks of whole views
    of about ``chunk_samples`` samples (the memory of one chunk; the scores do not depend on it)."""
    u_er, u_et, u_sem = [], [], []
    for poses in poses_in_chunks(views, intrinsics, n_samples, chunk_samples):
        out = render_uncertainty(source, intrinsics, poses, n_samples, delete_background=options.delete_background,
                                 min_ray_opacity=options.min_ray_opacity, min_occupancy=options.min_occupancy)
        h = out["h_ray"]
        if options.saturating_rays:
            h = 1.0 - torch.exp(-h / np.log(2.0))
        if options.soft_mask:
            mask = soft_target_mask(out["sem"], targets, options.mask_dilation)
        else:
            mask = target_mask(out["sem"], targets, options.mask_dilation)
        u_er.append(h.sum(dim=(1, 2)).cpu().numpy())
        u_et.append((h * mask).sum(dim=(1, 2)).cpu().numpy())
        u_sem.append(out["h_sem"].sum(dim=(1, 2)).cpu().numpy())
    u_er, u_et, u_sem = np.concatenate(u_er), np.concatenate(u_et), np.concatenate(u_sem)
    return Scores(exploration=u_er, exploitation=u_et, semantic=u_sem,
                  utility=u_et + options.epsilon * u_er + options.semantic_weight * u_sem)
