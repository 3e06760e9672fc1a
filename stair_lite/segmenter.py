"""A segmenter that makes mistakes: seeded label noise for measurements (beyond the paper; notebook 07).

The paper's simulator hands the planner perfect labels. A real segmentation network gets four things
wrong, and each is one switchable component here, applied in this order to a measurement's label image
(depth and colour stay exact, and so does the evaluation's ground truth, which renders its own views):

  missed detections  a whole object (a connected region of one class) is labelled background, with
                     probability  min(1, miss_base + miss_per_metre * max(0, d - miss_near) + miss_grazing * g),
                     d the region's median distance to the camera [m], g its median 1 - |cos| of the angle
                     between the viewing ray and the surface normal (0 facing the camera, 1 edge-on)
  class confusion    a whole object takes a look-alike class with probability ``confusion`` (``LOOK_ALIKES``)
  boundary errors    each pixel within ``boundary_px`` pixels of another label takes that label with
                     probability ``boundary_rate`` (masks that bleed over their edges)
  spurious blobs     a Poisson number (mean ``blobs_per_image``) of discs of a random object class, radius
                     uniform in ``blob_radius_px``, anywhere in the image (false positives)

``LABEL_NOISE`` names four levels: none, low, medium, high. ``NoisySegmenter`` applies one to each
measurement of a mission with a generator seeded by (seed, step), so a resumed mission sees the same labels.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage

from .classes import BACKGROUND, NUM_CLASSES, class_id
from .geometry import pixel_rays
from .measurement import Measurement

# Which class a confused object is taken for, with what share of the confusions. Look-alikes share a
# silhouette at a segmenter's resolution: seats (chair, sofa), legged furniture (chair, table),
# vehicles with a long body (car, airplane) and small dark boxes (camera, car).
LOOK_ALIKES: dict[str, dict[str, float]] = {
    "chair": {"sofa": 0.6, "table": 0.4},
    "sofa": {"chair": 1.0},
    "table": {"chair": 1.0},
    "car": {"airplane": 0.7, "camera": 0.3},
    "airplane": {"car": 1.0},
    "camera": {"car": 1.0},
}


def confusion_matrix(confusion: float) -> np.ndarray:
    """(P, P) matrix C[true, reported]: the probability that a whole object of class ``true`` is reported
    as ``reported``. Background is never confused (it is not an object); rows sum to 1."""
    matrix = np.eye(NUM_CLASSES)
    for true, others in LOOK_ALIKES.items():
        i = class_id(true)
        matrix[i, i] = 1.0 - confusion
        for other, share in others.items():
            matrix[i, class_id(other)] = confusion * share
    return matrix


@dataclass(frozen=True)
class LabelNoise:
    """The parameters of the four components (see the module docstring); zero switches one off."""

    miss_base: float = 0.0
    miss_per_metre: float = 0.0
    miss_near: float = 1.5  # [m] distances up to this one add nothing
    miss_grazing: float = 0.0
    confusion: float = 0.0
    boundary_px: int = 0
    boundary_rate: float = 0.0
    blobs_per_image: float = 0.0
    blob_radius_px: tuple[float, float] = (5.0, 15.0)

    def __post_init__(self):
        for name in ("miss_base", "miss_per_metre", "miss_grazing", "confusion", "boundary_rate", "blobs_per_image",
                     "miss_near", "boundary_px"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"label noise {name} must be a finite number >= 0, got {value!r}")
        for name in ("miss_base", "confusion", "boundary_rate"):
            if getattr(self, name) > 1:
                raise ValueError(f"label noise {name} is a probability, got {getattr(self, name)!r}")
        if int(self.boundary_px) != self.boundary_px:
            raise ValueError(f"label noise boundary_px must be a whole number of pixels, got {self.boundary_px!r}")
        low, high = self.blob_radius_px
        if not 0 < low <= high:
            raise ValueError(f"label noise blob_radius_px must be (low, high) with 0 < low <= high, got {self.blob_radius_px!r}")

    @property
    def is_exact(self) -> bool:
        """True when every component is off: the labels pass through unchanged."""
        return not (self.miss_base or self.miss_per_metre or self.miss_grazing or self.confusion
                    or (self.boundary_px and self.boundary_rate) or self.blobs_per_image)


# The named levels, for 400x400 measurements on the 2 m hemisphere (objects 1.2-2.8 m away).
LABEL_NOISE: dict[str, LabelNoise] = {
    "none": LabelNoise(),
    "low": LabelNoise(miss_base=0.0, miss_per_metre=0.05, miss_grazing=0.05, confusion=0.05,
                      boundary_px=2, boundary_rate=0.3, blobs_per_image=0.3, blob_radius_px=(4.0, 10.0)),
    "medium": LabelNoise(miss_base=0.02, miss_per_metre=0.1, miss_grazing=0.2, confusion=0.15,
                         boundary_px=4, boundary_rate=0.5, blobs_per_image=1.0, blob_radius_px=(6.0, 15.0)),
    "high": LabelNoise(miss_base=0.05, miss_per_metre=0.2, miss_grazing=0.4, confusion=0.3,
                       boundary_px=6, boundary_rate=0.7, blobs_per_image=3.0, blob_radius_px=(8.0, 25.0)),
}
EXACT = "none"


def label_noise(level: str) -> LabelNoise:
    """The named noise level; a clear error for an unknown name."""
    if level not in LABEL_NOISE:
        raise ValueError(f"unknown label noise level {level!r}; choose one of {', '.join(LABEL_NOISE)}")
    return LABEL_NOISE[level]


# ----------------------------------------------------------------------------- the components
def object_regions(labels: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """The objects a segmenter detects: (class, boolean mask) of each 8-connected region of one object class."""
    regions = []
    for cls in np.unique(labels):
        if cls == BACKGROUND:
            continue
        components, count = ndimage.label(labels == cls, structure=np.ones((3, 3)))
        regions += [(int(cls), components == k) for k in range(1, count + 1)]
    return regions


def grazing_image(m: Measurement) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel: distance to the camera [m] and 1 - |cos| of the angle between its ray and the surface normal
    estimated from the depth image (finite differences of the back-projected points; NaN where no hit)."""
    origins, dirs = pixel_rays(m.intrinsics, m.pose)
    h, w = m.depth.shape
    points = (origins + m.depth.reshape(-1, 1) * dirs).reshape(h, w, 3)
    normals = np.cross(np.gradient(points, axis=1), np.gradient(points, axis=0))
    unit_dirs = dirs.reshape(h, w, 3) / np.linalg.norm(dirs.reshape(h, w, 3), axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.abs((normals * unit_dirs).sum(-1)) / np.linalg.norm(normals, axis=-1)
    hit = m.depth > 0
    distance = np.where(hit, m.depth * np.linalg.norm(dirs.reshape(h, w, 3), axis=-1), np.nan)
    return distance, np.where(hit, 1.0 - np.nan_to_num(cos, nan=1.0), np.nan)


def miss_probability(noise: LabelNoise, distance: float, grazing: float) -> float:
    """The chance that an object at median ``distance`` [m] and median ``grazing`` (0..1) is missed."""
    p = noise.miss_base + noise.miss_per_metre * max(0.0, distance - noise.miss_near) + noise.miss_grazing * grazing
    return float(min(1.0, p))


def miss_objects(labels: np.ndarray, m: Measurement, noise: LabelNoise, rng: np.random.Generator) -> np.ndarray:
    """Missed detections: each object region becomes background with its ``miss_probability``."""
    out = labels.copy()
    distance, grazing = grazing_image(m)
    for _, mask in object_regions(labels):
        d, g = np.nanmedian(distance[mask]), np.nanmedian(grazing[mask])
        if rng.random() < miss_probability(noise, float(np.nan_to_num(d)), float(np.nan_to_num(g))):
            out[mask] = BACKGROUND
    return out


def confuse_objects(labels: np.ndarray, noise: LabelNoise, rng: np.random.Generator) -> np.ndarray:
    """Class confusion: each object region's class is redrawn from its row of ``confusion_matrix``."""
    out = labels.copy()
    matrix = confusion_matrix(noise.confusion)
    for cls, mask in object_regions(labels):
        out[mask] = rng.choice(NUM_CLASSES, p=matrix[cls])
    return out


def boundary_band(labels: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixels within ``width`` pixels (Euclidean) of a pixel of another label, and that nearest other label."""
    band = np.zeros(labels.shape, dtype=bool)
    other = labels.copy()
    for cls in np.unique(labels):
        inside = labels == cls
        if inside.all():
            continue
        distance, (rows, cols) = ndimage.distance_transform_edt(inside, return_indices=True)
        near = inside & (distance <= width)
        band |= near
        other[near] = labels[rows[near], cols[near]]
    return band, other


def bleed_boundaries(labels: np.ndarray, noise: LabelNoise, rng: np.random.Generator) -> np.ndarray:
    """Boundary errors: a band pixel takes its nearest other label with probability ``boundary_rate``."""
    band, other = boundary_band(labels, int(noise.boundary_px))
    flip = band & (rng.random(labels.shape) < noise.boundary_rate)
    return np.where(flip, other, labels)


def add_blobs(labels: np.ndarray, noise: LabelNoise, rng: np.random.Generator) -> np.ndarray:
    """Spurious blobs: discs of a random object class, a Poisson number of them at uniform centres."""
    out = labels.copy()
    h, w = labels.shape
    rows, cols = np.mgrid[0:h, 0:w]
    for _ in range(rng.poisson(noise.blobs_per_image)):
        radius = rng.uniform(*noise.blob_radius_px)
        r, c = rng.uniform(0, h), rng.uniform(0, w)
        out[(rows + 0.5 - r) ** 2 + (cols + 0.5 - c) ** 2 <= radius**2] = rng.integers(1, NUM_CLASSES)
    return out


def corrupt_labels(m: Measurement, noise: LabelNoise, rng: np.random.Generator) -> np.ndarray:
    """The label image a segmenter with ``noise`` reports for measurement ``m`` (the components in order)."""
    labels = np.asarray(m.labels)
    if noise.miss_base or noise.miss_per_metre or noise.miss_grazing:
        labels = miss_objects(labels, m, noise, rng)
    if noise.confusion:
        labels = confuse_objects(labels, noise, rng)
    if noise.boundary_px and noise.boundary_rate:
        labels = bleed_boundaries(labels, noise, rng)
    if noise.blobs_per_image:
        labels = add_blobs(labels, noise, rng)
    return labels


class NoisySegmenter:
    """Replaces each measurement's exact labels by those of a segmenter with a named noise ``level``; the
    generator of step k is seeded by (seed, k), so the same mission step always gets the same labels."""

    def __init__(self, level: str = EXACT, seed: int = 0):
        self.level, self.noise, self.seed = level, label_noise(level), seed

    def __call__(self, m: Measurement, step: int) -> Measurement:
        if self.noise.is_exact:
            return m
        rng = np.random.default_rng([self.seed, step, 0x5E6])
        return replace(m, labels=corrupt_labels(m, self.noise, rng))


def label_error_rate(exact: np.ndarray, reported: np.ndarray) -> dict[str, float]:
    """How wrong a reported label image is: the fraction of wrong pixels, of object pixels reported as another
    class (by any component: missed, confused, bled over or covered by a blob) and of background pixels reported
    as an object (spurious)."""
    exact, reported = np.asarray(exact), np.asarray(reported)
    objects = exact != BACKGROUND
    return {"wrong": float(np.mean(exact != reported)),
            "objects_lost": float(np.mean(reported[objects] != exact[objects])) if objects.any() else 0.0,
            "spurious": float(np.mean(reported[~objects] != BACKGROUND)) if (~objects).any() else 0.0}

