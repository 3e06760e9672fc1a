"""Checkers for the exercises of notebook 01 (the scene and the sensor).

Each ``check_*`` takes the learner's function, calls it on several seeded random inputs, compares
the answers with an independent computation written here in plain numpy, and raises
``AssertionError`` with a hint when they differ. Where a wrong answer matches a common mistake
(a principal point off by a fraction of a pixel, swapping x and y, using range instead of z-depth, ...) the hint
names that mistake. On success a checker prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np

from ..geometry import HEMISPHERE_RADIUS, Intrinsics, view_to_pose
from ..measurement import Measurement, back_project
from .common import as_array as _as_array, call as _call, compares_with

_ATOL = 1e-6


def _random_K(rng: np.random.Generator) -> np.ndarray:
    """A pinhole K with fx != fy and an off-centre principal point, so swapped axes show up."""
    fx, fy = rng.uniform(80.0, 400.0, size=2)
    cx, cy = rng.uniform(20.0, 200.0, size=2)
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def _random_pose(rng: np.random.Generator) -> np.ndarray:
    """A look-at pose of a random hemisphere view at a random radius."""
    elevation = rng.uniform(0.05, 1.5)
    azimuth = rng.uniform(0.0, 2 * np.pi)
    return view_to_pose(elevation, azimuth, radius=rng.uniform(1.5, 3.0))


def _close(a, b, atol: float = _ATOL) -> bool:
    return bool(np.allclose(a, b, atol=atol, rtol=1e-7))


# --------------------------------------------------------------------------------------------------
# Exercise 1: the same camera at another resolution
# --------------------------------------------------------------------------------------------------
def _scaled_reference(K, factor):
    return np.array([[K[0, 0] * factor, 0.0, K[0, 2] * factor], [0.0, K[1, 1] * factor, K[1, 2] * factor], [0.0, 0.0, 1.0]])


def _scaled_variants(K, factor) -> dict[str, np.ndarray]:
    """The right matrix and what common mistakes give instead."""
    right = _scaled_reference(K, factor)
    centres_at_integers = right.copy()
    centres_at_integers[:2, 2] = factor * (K[:2, 2] + 0.5) - 0.5
    focal_kept, centre_kept, inverse = right.copy(), right.copy(), _scaled_reference(K, 1.0 / factor)
    focal_kept[0, 0], focal_kept[1, 1] = K[0, 0], K[1, 1]
    centre_kept[:2, 2] = K[:2, 2]
    return {"right": right, "centres_at_integers": centres_at_integers, "focal_kept": focal_kept,
            "centre_kept": centre_kept, "inverse": inverse, "all": K * factor}


_SCALED_HINTS = {
    "centres_at_integers": ("off by a fraction of a pixel: s (c + 0.5) - 0.5 is the rule where pixel centres sit at integer "
                            "coordinates; here pixel u spans [u, u + 1), so continuous image coordinates simply scale, "
                            "u' = s u, and so does the principal point"),
    "focal_kept": ("the field of view stays the same, so the focal length in pixels shrinks with the image: fx' = s fx "
                   "(f = (W / 2) / tan(FOV / 2) with W' = s W)"),
    "centre_kept": "the principal point moves with the image: at W' = s W pixels it is at s cx (still the image centre)",
    "inverse": "you divided by the factor: a factor of 0.25 turns 400 x 400 into 100 x 100, and every pixel length shrinks by it",
    "all": "the bottom-right entry of K stays 1 (it is the homogeneous coordinate, not a length)",
}


@compares_with(_scaled_reference)
def check_scale_intrinsics(scale_intrinsics, n_trials: int = 40, seed: int = 0) -> bool:
    """``scale_intrinsics(K, factor)`` returns the 3x3 K of the same camera rendering ``factor`` times as many pixels
    along each axis (0.25: 400 x 400 -> 100 x 100), with the convention that pixel u spans [u, u + 1)."""
    rng = np.random.default_rng(seed)
    cases = [(_random_K(rng), float(rng.choice([0.1, 0.2, 0.25, 0.5, 2.0]))) for _ in range(n_trials)]
    for K, factor in cases:
        got = _as_array(_call(scale_intrinsics, K.copy(), factor), (3, 3), "scale_intrinsics(K, factor)")
        variants = _scaled_variants(K, factor)
        if _close(got, variants["right"]):
            continue
        hint = next((h for name, h in _SCALED_HINTS.items() if _close(got, variants[name])),
                    "which entries of K are lengths in pixels, and which do not change when the image is resized?")
        raise AssertionError(f"scale_intrinsics is wrong for factor {factor} and K =\n{np.round(K, 3)}\nyou returned\n"
                             f"{np.round(got, 4)}\nexpected\n{np.round(variants['right'], 4)}\nHint: {hint}")
    print(f"check_scale_intrinsics: {n_trials} random cameras and factors agree")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 2: projecting world points into the image
# --------------------------------------------------------------------------------------------------
def _project_reference(points, pose, K):
    R, t = pose[:3, :3], pose[:3, 3]
    cam = (points - t) @ R  # R^T (p - t), row-wise
    uv = np.stack([K[0, 0] * cam[:, 0] / cam[:, 2] + K[0, 2], K[1, 1] * cam[:, 1] / cam[:, 2] + K[1, 2]], axis=1)
    return uv, cam[:, 2]


def _project_hint(points, pose, K, uv, z) -> str:
    want_uv, want_z = _project_reference(points, pose, K)
    cam = (points - pose[:3, 3]) @ pose[:3, :3]
    if _close(uv, want_uv) and _close(z, np.linalg.norm(cam, axis=1)):
        return "the pixel coordinates are right but the depth is the range |p_cam|: return the z-depth p_cam[2]"
    if _close(uv, want_uv[:, ::-1]):
        return "u and v are swapped: u (column) comes from the camera x axis, v (row) from the camera y axis"
    if _close(uv, want_uv - 0.5) or _close(uv, want_uv + 0.5):
        return "off by half a pixel: the image coordinates are fx * x / z + cx with no extra 0.5 (pixel u spans [u, u + 1))"
    wrong_cam = np.c_[points, np.ones(len(points))] @ pose.T
    if _close(z, wrong_cam[:, 2]):
        return "you applied the camera-to-world pose to world points: use its inverse, p_cam = R^T (p_world - t)"
    if _close(uv, cam[:, :2] * np.diag(K)[:2] + K[:2, 2]):
        return "you forgot the perspective division by the depth z"
    return "world -> camera: p_cam = R^T (p_world - t); camera -> image: (fx x / z + cx, fy y / z + cy); depth = z"


@compares_with(_project_reference)
def check_project(project, n_trials: int = 10, seed: int = 0) -> bool:
    """``project(points, pose, K)`` takes world points (N, 3), an OpenCV camera-to-world pose and K and
    returns ``(uv, z)``: continuous image coordinates (N, 2) (pixel (u, v) spans [u, u+1) x [v, v+1),
    its centre is (u + 0.5, v + 0.5)) and z-depths (N,).

    Two tests: random world points against an independent projection, and a round trip with
    ``stair_lite.measurement.back_project`` (every back-projected pixel must land on its own centre
    at its own depth)."""
    rng = np.random.default_rng(seed)
    for trial in range(n_trials):
        K, pose = _random_K(rng), _random_pose(rng)
        n = 40
        # points in front of the camera: random camera-frame points, taken to the world frame
        cam = np.c_[rng.uniform(-1, 1, size=(n, 2)), rng.uniform(0.5, 4.0, size=n)]
        points = cam @ pose[:3, :3].T + pose[:3, 3]
        out = _call(project, points.copy(), pose.copy(), K.copy())
        if out is None:
            raise AssertionError("project(points, pose, K) returned None: fill in the function body (it still looks like the stub)")
        if not isinstance(out, tuple) or len(out) != 2:
            raise AssertionError("project(points, pose, K) must return a tuple (uv, z)")
        uv = _as_array(out[0], (n, 2), "project(...)[0] (uv)")
        z = _as_array(out[1], (n,), "project(...)[1] (z)")
        want_uv, want_z = _project_reference(points, pose, K)
        if not (_close(uv, want_uv, 1e-5) and _close(z, want_z)):
            i = int(np.argmax(np.abs(uv - want_uv).sum(axis=1) + np.abs(z - want_z)))
            raise AssertionError(
                f"project is wrong: world point {np.round(points[i], 4)} gave uv={np.round(uv[i], 4)}, z={z[i]:.4f}; "
                f"expected uv={np.round(want_uv[i], 4)}, z={want_z[i]:.4f}\nHint: {_project_hint(points, pose, K, uv, z)}"
            )

    # Round trip: a synthetic depth image back-projected by stair_lite must project onto its pixel centres.
    h, w = 30, 40
    intr = Intrinsics(w, h, fx=50.0, fy=45.0, cx=19.0, cy=16.5)
    depth = rng.uniform(0.5, 3.0, size=(h, w)).astype(np.float32)
    depth[rng.uniform(size=(h, w)) < 0.2] = 0.0  # some pixels hit nothing
    pose = _random_pose(rng)
    m = Measurement(np.ones((h, w, 3), np.float32), depth, np.zeros((h, w), np.int64), pose, intr)
    points, _, _ = back_project(m)
    uv, z = _call(project, points, pose, intr.K)
    vv, uu = np.nonzero(depth > 0)
    centres = np.stack([uu + 0.5, vv + 0.5], axis=1)
    uv, z = np.asarray(uv, float), np.asarray(z, float)
    if not _close(uv, centres, 1e-4):
        raise AssertionError(
            "round trip failed: back_project(pixel) followed by your project() does not land on the pixel centre "
            f"(first pixel: expected {centres[0]}, got {np.round(uv[0], 4)})\nHint: {_project_hint(points, pose, intr.K, uv, z)}"
        )
    if not _close(z, depth[depth > 0], 1e-4):
        raise AssertionError(
            "round trip failed: the depth you return is not the depth-image value (z-depth)\n"
            f"Hint: {_project_hint(points, pose, intr.K, uv, z)}"
        )
    print(f"check_project: {n_trials} x 40 random points agree, and the round trip through back_project is exact")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 3: the angle between two views
# --------------------------------------------------------------------------------------------------
def _unit(view) -> np.ndarray:
    el, az = view
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def _angle_reference(a, b) -> float:
    return float(np.arccos(np.clip(_unit(a) @ _unit(b), -1.0, 1.0)))


@compares_with(_angle_reference)
def check_view_angle(view_angle, n_trials: int = 200, seed: int = 0) -> bool:
    """``view_angle(view_a, view_b)`` takes two views (elevation, azimuth) in radians and returns the
    great-circle angle in radians between the two camera directions (as seen from the origin)."""
    rng = np.random.default_rng(seed)
    pairs = [
        ((np.pi / 2, 0.0), (np.pi / 2, 2.0)),  # the top view is one point whatever its azimuth
        ((0.3, 0.05), (0.3, 2 * np.pi - 0.05)),  # across the azimuth seam
        ((0.0, 0.0), (0.0, np.pi)),  # opposite on the horizon
        ((1.2, 1.0), (1.2, 1.0)),  # the same view
    ]
    for _ in range(n_trials):
        pairs.append(tuple((rng.uniform(0, np.pi / 2), rng.uniform(0, 2 * np.pi)) for _ in range(2)))
    for _ in range(n_trials // 4):  # identical views: rounding takes d_a . d_b just above 1 for some of them
        view = (rng.uniform(0, np.pi / 2), rng.uniform(0, 2 * np.pi))
        pairs.append((view, view))
    for a, b in pairs:
        got = _call(view_angle, a, b)
        if got is None:
            raise AssertionError("view_angle(view_a, view_b) returned None: fill in the function body")
        got = float(np.asarray(got).reshape(()))
        want = _angle_reference(a, b)
        if np.isnan(got):
            raise AssertionError(
                f"view_angle returned NaN for views {np.round(a, 4)} and {np.round(b, 4)}\nHint: rounding can take the "
                "dot product of two unit vectors just past 1 (the same view twice): clip it to [-1, 1] before arccos")
        if abs(got - want) <= 1e-6:
            continue
        if abs(got - 2 * np.sin(want / 2)) <= 1e-6 or abs(got - 4 * np.sin(want / 2)) <= 1e-6:
            hint = "that is the straight-line (chord) distance: return the angle, arccos(d_a . d_b)"
        elif abs(got - np.hypot(a[0] - b[0], a[1] - b[1])) <= 1e-6:
            hint = "(elevation, azimuth) is not a flat plane: turn each view into a unit vector on the sphere first"
        elif abs(got - np.degrees(want)) <= 1e-4:
            hint = "return radians, not degrees"
        else:
            hint = ("check two views you know: the top view against a view on the horizon (90 deg), and two opposite views on "
                    "the horizon (180 deg); compute the angle between the views' directions, not between their (el, az) pairs")
        raise AssertionError(
            f"view_angle is wrong for views {np.round(a, 4)} and {np.round(b, 4)}: got {got:.6f}, expected {want:.6f}\nHint: {hint}"
        )
    print(f"check_view_angle: {len(pairs)} view pairs agree (including the top view and the azimuth seam)")
    return True


# --------------------------------------------------------------------------------------------------
# The look-at pose (section 2): a view on the hemisphere -> the camera-to-world pose
# --------------------------------------------------------------------------------------------------
def _view_to_pose_reference(elevation, azimuth, radius=HEMISPHERE_RADIUS):
    t = radius * np.array([np.cos(azimuth) * np.cos(elevation), np.sin(azimuth) * np.cos(elevation), np.sin(elevation)])
    forward = -t / np.linalg.norm(t)
    up = np.array([0.0, 0.0, 1.0]) if np.pi / 2 - elevation >= 1e-6 else -np.array([np.cos(azimuth), np.sin(azimuth), 0.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([right, np.cross(forward, right), forward], axis=1)
    pose[:3, 3] = t
    return pose


def _view_to_pose_hint(got, want, elevation) -> str:
    R, t = got[:3, :3], got[:3, 3]
    if not np.all(np.isfinite(got)):
        return ("the pose has NaN entries: at the top view forward is parallel to world up, so z x up = 0 cannot be "
                "normalised; use the documented image-up vector -(cos az, sin az, 0) there")
    if _close(t, want[:3, 3]) and _close(R, want[:3, :3].T):
        return "the rotation is transposed: its COLUMNS are the camera axes x, y, z written in world coordinates"
    if _close(t, want[:3, 3]) and _close(R[:, 2], -want[:3, 2]):
        return ("the camera looks away from the origin (or uses OpenGL's -z forward): OpenCV's z axis points forward, "
                "z = -t / |t|")
    if _close(t, want[:3, 3]) and _close(R[:, 2], want[:3, 2]) and _close(R[:, 0], -want[:3, 0]):
        return ("x points left: x = z x up (forward cross up), in that order; then y = z x x points down and the frame "
                "is right-handed (det R = +1)")
    if _close(R, want[:3, :3]) and _close(t, 0.0):
        return "the translation column is the camera centre t on the hemisphere, not zero"
    if _close(R, want[:3, :3]) and not _close(t, want[:3, 3]):
        return ("the camera centre is off: t = r (cos az cos el, sin az cos el, sin el); elevation is measured up from "
                "the ground plane, azimuth around the z axis")
    return ("pose = [x y z | t] with t = r (cos az cos el, sin az cos el, sin el), z = -t/|t|, x = z x up normalised, "
            "y = z x x, up = (0, 0, 1) except at the top view")


@compares_with(_view_to_pose_reference)
def check_view_to_pose(view_to_pose, n_trials: int = 60, seed: int = 0) -> bool:
    """``view_to_pose(elevation, azimuth, radius)`` returns the 4x4 OpenCV camera-to-world pose of a camera at the view
    on the hemisphere of ``radius``, looking at the origin (x right, y down, z forward), with the top view's image up
    -(cos az, sin az, 0)."""
    rng = np.random.default_rng(seed)
    cases = [(rng.uniform(0.0, 1.5), rng.uniform(0.0, 2 * np.pi), rng.uniform(1.0, 3.0)) for _ in range(n_trials)]
    cases += [(np.pi / 2, 0.0, 2.0), (np.pi / 2, 1.3, 2.5), (0.0, 0.7, 2.0)]
    for elevation, azimuth, radius in cases:
        got = _as_array(_call(view_to_pose, elevation, azimuth, radius), (4, 4), "view_to_pose(elevation, azimuth, radius)")
        want = _view_to_pose_reference(elevation, azimuth, radius)
        if not _close(got, want):
            raise AssertionError(f"view_to_pose is wrong at elevation {elevation:.3f}, azimuth {azimuth:.3f}, radius "
                                 f"{radius:.2f}: you returned\n{np.round(got, 4)}\nexpected\n{np.round(want, 4)}\n"
                                 f"Hint: {_view_to_pose_hint(got, want, elevation)}")
    print(f"check_view_to_pose: {len(cases)} views (the top view included) agree")
    return True


# --------------------------------------------------------------------------------------------------
# Back-projection (section 5): a depth image -> world points
# --------------------------------------------------------------------------------------------------
def _back_project_reference(m):
    k = m.intrinsics
    v, u = np.mgrid[0 : k.height, 0 : k.width]
    cam = np.stack([(u + 0.5 - k.cx) / k.fx, (v + 0.5 - k.cy) / k.fy, np.ones(u.shape)], axis=-1).reshape(-1, 3)
    depth = np.asarray(m.depth, np.float64).reshape(-1)
    hit = depth > 0
    return (cam[hit] * depth[hit, None]) @ m.pose[:3, :3].T + m.pose[:3, 3], np.asarray(m.labels).reshape(-1)[hit]


def _random_measurement(rng: np.random.Generator) -> Measurement:
    """A small measurement of random depths (a fifth of the pixels without a hit) from a random pose, with a camera
    whose fx != fy and whose principal point is off-centre."""
    w, h = int(rng.integers(7, 13)), int(rng.integers(5, 11))
    k = Intrinsics(w, h, rng.uniform(5.0, 15.0), rng.uniform(5.0, 15.0), rng.uniform(2.0, w - 2.0), rng.uniform(2.0, h - 2.0))
    depth = rng.uniform(0.5, 3.0, size=(h, w)) * (rng.random((h, w)) > 0.2)
    return Measurement(rgb=rng.random((h, w, 3)), depth=depth, labels=rng.integers(0, 7, size=(h, w)),
                       pose=_random_pose(rng), intrinsics=k)


def _back_project_hint(m, points) -> str:
    k, pose = m.intrinsics, m.pose
    v, u = np.mgrid[0 : k.height, 0 : k.width]
    depth = np.asarray(m.depth, np.float64).reshape(-1)
    hit = depth > 0

    def world(cam, scale_to_range=False):
        cam = cam.reshape(-1, 3)[hit]
        if scale_to_range:
            cam = cam / np.linalg.norm(cam, axis=1, keepdims=True)
        return (cam * depth[hit, None]) @ pose[:3, :3].T + pose[:3, 3]

    ones = np.ones(u.shape)
    right = np.stack([(u + 0.5 - k.cx) / k.fx, (v + 0.5 - k.cy) / k.fy, ones], axis=-1)
    if points.shape != (int(hit.sum()), 3):
        return (f"expected one point per pixel with a depth hit ({int(hit.sum())} of {depth.size}, depth > 0), got shape "
                f"{points.shape}: leave out the pixels of depth 0 (no hit)")
    if _close(points, world(np.stack([(u - k.cx) / k.fx, (v - k.cy) / k.fy, ones], axis=-1))):
        return "off by half a pixel: pixel (u, v) spans [u, u + 1), so its ray goes through its centre (u + 0.5, v + 0.5)"
    if _close(points, world(right, scale_to_range=True)):
        return ("the depth image holds z-depth, not range: scale the ray whose z component is 1 by the depth (do not "
                "normalise it to unit length)")
    if _close(points, world(np.stack([(v + 0.5 - k.cx) / k.fx, (u + 0.5 - k.cy) / k.fy, ones], axis=-1))):
        return "u and v are swapped: u is the column (x, width) and v the row (y, height); np.mgrid gives rows first"
    if _close(points, (right.reshape(-1, 3)[hit] * depth[hit, None] - pose[:3, 3]) @ pose[:3, :3]):
        return "you applied the inverse pose (world -> camera): camera points go to the world as R p + t"
    return "p_world = R (d K^-1 (u + 0.5, v + 0.5, 1)) + t for every pixel with d > 0, in row-major pixel order"


@compares_with(_back_project_reference)
def check_back_project(back_project, n_trials: int = 12, seed: int = 0) -> bool:
    """``back_project(m)`` takes a ``Measurement`` and returns ``(points, labels)``: the world point (N, 3) of every pixel
    with a depth hit (depth > 0), in row-major pixel order, and those pixels' labels (N,)."""
    rng = np.random.default_rng(seed)
    for _ in range(n_trials):
        m = _random_measurement(rng)
        answer = _call(back_project, m)
        if not isinstance(answer, tuple) or len(answer) != 2:
            raise AssertionError(f"back_project(m) should return a pair (points, labels), got {type(answer).__name__}")
        points, labels = np.asarray(answer[0], np.float64), np.asarray(answer[1])
        want_points, want_labels = _back_project_reference(m)
        if points.shape != want_points.shape or not _close(points, want_points):
            raise AssertionError(f"back_project is wrong for a {m.intrinsics.width}x{m.intrinsics.height} measurement.\n"
                                 f"Hint: {_back_project_hint(m, points)}")
        if labels.shape != want_labels.shape or not np.array_equal(labels, want_labels):
            raise AssertionError("the points are right but the labels are not: return the labels of the same pixels "
                                 "(those with depth > 0), in the same order")
    print(f"check_back_project: {n_trials} random measurements agree")
    return True
