"""Camera geometry: intrinsics, look-at poses on the hemisphere, view samplers and pixel rays.

Introduced in notebook 01. Conventions (README, Design): metres, world z up; a pose is a 4x4
camera-to-world matrix in the OpenCV convention (x right, y down, z forward); a *view* is
(elevation, azimuth) in radians on the hemisphere of radius 2 m, looking at the origin.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

HEMISPHERE_RADIUS = 2.0
# The reference code's lowest camera height is 1 cm: elevation >= arcsin(0.01 / 2) ~ 0.005 rad.
MIN_ELEVATION = float(np.arcsin(0.01 / HEMISPHERE_RADIUS))
TOP_VIEW = (np.pi / 2, 0.0)


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics; pixel (u, v) has its centre at (u + 0.5, v + 0.5)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self):
        for name in ("width", "height"):
            value = getattr(self, name)
            if int(value) != value or value <= 0:
                raise ValueError(f"image {name} must be a positive integer, got {value!r}")
        for name in ("fx", "fy"):
            if not np.isfinite(getattr(self, name)) or getattr(self, name) <= 0:
                raise ValueError(f"focal length {name} must be positive, got {getattr(self, name)!r}")

    @classmethod
    def from_fov(cls, width: int = 400, height: int = 400, fov_deg: float = 90.0) -> "Intrinsics":
        """Square-pixel intrinsics whose horizontal field of view is ``fov_deg`` degrees."""
        if not 0.0 < fov_deg < 180.0:
            raise ValueError(f"field of view must lie in (0, 180) degrees, got {fov_deg!r}")
        if int(width) != width or width <= 0 or int(height) != height or height <= 0:
            raise ValueError(f"image size must be positive integers, got width={width!r}, height={height!r}")
        f = (width / 2.0) / np.tan(np.radians(fov_deg) / 2.0)
        return cls(int(width), int(height), float(f), float(f), width / 2.0, height / 2.0)

    @property
    def K(self) -> np.ndarray:
        """The 3x3 calibration matrix."""
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1]], dtype=np.float64)

    @property
    def fov_y_rad(self) -> float:
        """Vertical field of view in radians (what pyrender's camera takes)."""
        return float(2.0 * np.arctan(self.height / (2.0 * self.fy)))

    def scaled(self, factor: float) -> "Intrinsics":
        """The same camera at ``factor`` times the resolution (e.g. 0.2 turns 400x400 into 80x80)."""
        w, h = round(self.width * factor), round(self.height * factor)
        if w <= 0 or h <= 0:
            raise ValueError(f"scale factor {factor!r} gives an empty image ({w}x{h})")
        sx, sy = w / self.width, h / self.height
        return Intrinsics(w, h, self.fx * sx, self.fy * sy, self.cx * sx, self.cy * sy)


def look_at(position, target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """OpenCV camera-to-world pose at ``position`` looking at ``target``; image 'up' follows ``up``."""
    position = np.asarray(position, dtype=np.float64)
    forward = np.asarray(target, dtype=np.float64) - position
    norm = np.linalg.norm(forward)
    if norm < 1e-9:
        raise ValueError(f"camera position {position.tolist()} coincides with the look-at target")
    z = forward / norm
    x = np.cross(z, np.asarray(up, dtype=np.float64))
    if np.linalg.norm(x) < 1e-9:
        raise ValueError(f"up vector {list(up)} is parallel to the viewing direction; give another up vector")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = x, y, z, position
    return pose


def view_to_position(elevation, azimuth, radius: float = HEMISPHERE_RADIUS) -> np.ndarray:
    """Camera centre for views (elevation, azimuth) in radians: r (cos az cos el, sin az cos el, sin el)."""
    el, az = np.asarray(elevation, dtype=np.float64), np.asarray(azimuth, dtype=np.float64)
    return radius * np.stack([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), np.sin(el)], axis=-1)


def view_to_pose(elevation: float, azimuth: float, radius: float = HEMISPHERE_RADIUS) -> np.ndarray:
    """Look-at-origin pose of one view.

    Image 'up' is the projection of world +z. At the top view (elevation 90 deg) that projection
    vanishes, so we use the limit from just below: image up = -(cos az, sin az, 0); for the default
    top view (azimuth 0) image up is world -x, as in the reference code.
    """
    if not -1e-9 <= elevation <= np.pi / 2 + 1e-9:
        raise ValueError(f"elevation must lie in [0, pi/2] rad on the hemisphere, got {elevation!r}")
    position = view_to_position(elevation, azimuth, radius)
    if np.pi / 2 - elevation < 1e-6:
        return look_at(position, up=(-np.cos(azimuth), -np.sin(azimuth), 0.0))
    return look_at(position)


def pose_to_view(pose: np.ndarray) -> tuple[float, float]:
    """(elevation, azimuth) in radians of a camera centre (the inverse of ``view_to_pose`` for look-at poses)."""
    x, y, z = np.asarray(pose)[:3, 3]
    elevation = float(np.arctan2(z, np.hypot(x, y)))
    azimuth = float(np.arctan2(y, x) % (2 * np.pi)) if np.hypot(x, y) > 1e-9 else 0.0
    return elevation, azimuth


def views_to_directions(views: np.ndarray) -> np.ndarray:
    """Unit vectors from the origin to the cameras of views (N, 2)."""
    views = np.asarray(views, dtype=np.float64).reshape(-1, 2)
    return view_to_position(views[:, 0], views[:, 1], radius=1.0)


def angular_distance(views_a: np.ndarray, views_b: np.ndarray) -> np.ndarray:
    """Great-circle angle (radians) between every view of ``views_a`` (N, 2) and ``views_b`` (M, 2): (N, M)."""
    cos = views_to_directions(views_a) @ views_to_directions(views_b).T
    return np.arccos(np.clip(cos, -1.0, 1.0))


def view_spread(views: np.ndarray) -> float:
    """The mean great-circle angle (radians) between two of the views (N, 2), N >= 2: how widely a mission looked."""
    views = np.asarray(views, dtype=float)
    if views.ndim != 2 or views.shape[1] != 2 or len(views) < 2:
        raise ValueError(f"view_spread needs at least two views as (N, 2) [elevation, azimuth], got shape {views.shape}")
    return float(angular_distance(views, views)[np.triu_indices(len(views), 1)].mean())


def fibonacci_hemisphere(n: int, azimuth_offset: float = 0.0, min_elevation: float = MIN_ELEVATION) -> np.ndarray:
    """``n`` evenly spread views: n rings of equal area (z = (i + 0.5) / n), golden-angle azimuths.

    Returns (n, 2) [elevation, azimuth], lowest ring first.
    """
    if n < 1:
        raise ValueError(f"number of views must be at least 1, got {n!r}")
    i = np.arange(n)
    z = (i + 0.5) / n
    elevation = np.maximum(np.arcsin(z), min_elevation)
    azimuth = (np.pi * (3.0 - np.sqrt(5.0)) * i + azimuth_offset) % (2 * np.pi)
    return np.stack([elevation, azimuth], axis=1)


def random_hemisphere(n: int, rng: np.random.Generator, min_elevation: float = MIN_ELEVATION) -> np.ndarray:
    """``n`` area-uniform random views: sin(elevation) ~ U(sin(min_elevation), 1), azimuth ~ U(0, 2 pi)."""
    if n < 0:
        raise ValueError(f"number of views must be non-negative, got {n!r}")
    sin_el = rng.uniform(np.sin(min_elevation), 1.0, size=n)
    azimuth = rng.uniform(0.0, 2 * np.pi, size=n)
    return np.stack([np.arcsin(sin_el), azimuth], axis=1)


def local_views(
    view,
    n: int,
    rng: np.random.Generator,
    min_angle: float = 0.1,
    max_angle: float = 0.5,
    min_elevation: float = MIN_ELEVATION,
) -> np.ndarray:
    """``n`` views around ``view`` at great-circle angles ~ U[min_angle, max_angle] rad in random directions.

    Samples that fall below ``min_elevation`` are redrawn (the paper's resampling stage, N_re).
    """
    if not 0.0 <= min_angle <= max_angle < np.pi / 2:
        raise ValueError(f"need 0 <= min_angle <= max_angle < pi/2, got [{min_angle!r}, {max_angle!r}]")
    centre = views_to_directions(view)[0]
    helper = np.array([1.0, 0.0, 0.0]) if abs(centre[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(centre, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(centre, e1)
    out = np.empty((0, 2))
    while len(out) < n:
        m = 2 * (n - len(out)) + 8
        angle = rng.uniform(min_angle, max_angle, size=m)
        heading = rng.uniform(0.0, 2 * np.pi, size=m)
        tangent = np.cos(heading)[:, None] * e1 + np.sin(heading)[:, None] * e2
        d = np.cos(angle)[:, None] * centre + np.sin(angle)[:, None] * tangent
        elevation = np.arcsin(np.clip(d[:, 2], -1.0, 1.0))
        azimuth = np.arctan2(d[:, 1], d[:, 0]) % (2 * np.pi)
        keep = elevation >= min_elevation
        out = np.concatenate([out, np.stack([elevation[keep], azimuth[keep]], axis=1)])
    return out[:n]


def test_views(n: int = 100) -> np.ndarray:
    """The fixed evaluation views: ``n`` Fibonacci views (the paper renders 100 test views)."""
    return fibonacci_hemisphere(n, azimuth_offset=0.5)


test_views.__test__ = False  # not a pytest test despite its name


def pixel_rays(intrinsics: Intrinsics, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-space rays through every pixel centre, row-major: origins (H*W, 3), directions (H*W, 3).

    Directions are *not* normalised: their camera-frame z component is 1, so a point at ray
    parameter t lies at z-depth t, the quantity the depth images hold (as in the reference code).
    """
    u, v = np.meshgrid(np.arange(intrinsics.width), np.arange(intrinsics.height))
    cam = np.stack(
        [(u + 0.5 - intrinsics.cx) / intrinsics.fx, (v + 0.5 - intrinsics.cy) / intrinsics.fy, np.ones_like(u, float)],
        axis=-1,
    ).reshape(-1, 3)
    pose = np.asarray(pose, dtype=np.float64)
    directions = cam @ pose[:3, :3].T
    origins = np.broadcast_to(pose[:3, 3], directions.shape).copy()
    return origins, directions
