"""The checkers of notebook 01's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest

from stair_lite.exercises.sensor import check_pixel_to_ray, check_project, check_view_angle
from stair_lite.geometry import angular_distance


# ---- exercise 1: pixel -> camera ray ------------------------------------------------------------
def ray_ok(u, v, K):
    return np.linalg.inv(K) @ np.array([u + 0.5, v + 0.5, 1.0])


def ray_no_centre(u, v, K):
    return np.linalg.inv(K) @ np.array([u, v, 1.0])


def ray_normalised(u, v, K):
    d = ray_ok(u, v, K)
    return d / np.linalg.norm(d)


def ray_swapped(u, v, K):
    return ray_ok(v, u, K)


def ray_stub(u, v, K):
    return None


def test_pixel_to_ray_accepts_correct():
    assert check_pixel_to_ray(ray_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [(ray_no_centre, "CENTRE"), (ray_normalised, "normalised"), (ray_swapped, "swapped"), (ray_stub, "None")],
)
def test_pixel_to_ray_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_pixel_to_ray(wrong)


# ---- exercise 2: world -> image ---------------------------------------------------------------
def project_ok(points, pose, K):
    R, t = pose[:3, :3], pose[:3, 3]
    cam = (points - t) @ R
    pix = cam @ K.T
    return pix[:, :2] / pix[:, 2:], cam[:, 2]


def project_range(points, pose, K):
    uv, _ = project_ok(points, pose, K)
    return uv, np.linalg.norm(points - pose[:3, 3], axis=1)


def project_swapped(points, pose, K):
    uv, z = project_ok(points, pose, K)
    return uv[:, ::-1], z


def project_c2w(points, pose, K):
    cam = points @ pose[:3, :3].T + pose[:3, 3]  # applies the camera-to-world pose: wrong direction
    pix = cam @ K.T
    return pix[:, :2] / pix[:, 2:], cam[:, 2]


def project_half_pixel(points, pose, K):
    uv, z = project_ok(points, pose, K)
    return uv - 0.5, z


def project_stub(points, pose, K):
    return None


def test_project_accepts_correct():
    assert check_project(project_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (project_range, "range"),
        (project_swapped, "swapped"),
        (project_c2w, "inverse"),
        (project_half_pixel, "half a pixel"),
        (project_stub, "None"),
    ],
)
def test_project_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_project(wrong)


# ---- exercise 3: angle between views ----------------------------------------------------------
def angle_ok(a, b):
    return angular_distance(np.array([a]), np.array([b]))[0, 0]


def angle_flat(a, b):
    return np.hypot(a[0] - b[0], a[1] - b[1])


def angle_chord(a, b):
    return 2 * np.sin(angle_ok(a, b) / 2)


def angle_degrees(a, b):
    return np.degrees(angle_ok(a, b))


def angle_colatitude(a, b):
    # spherical law of cosines but with colatitude/latitude mixed up: a plausible slip
    return np.arccos(np.clip(np.cos(a[0]) * np.cos(b[0]) + np.sin(a[0]) * np.sin(b[0]) * np.cos(a[1] - b[1]), -1, 1))


def angle_unclipped(a, b):
    def unit(v):
        return np.array([np.cos(v[0]) * np.cos(v[1]), np.cos(v[0]) * np.sin(v[1]), np.sin(v[0])])
    with np.errstate(invalid="ignore"):
        return float(np.arccos(unit(a) @ unit(b)))  # NaN where rounding takes the dot product past 1


def test_view_angle_accepts_correct():
    assert check_view_angle(angle_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [(angle_flat, "flat plane"), (angle_chord, "chord"), (angle_degrees, "degrees"), (angle_colatitude, "view_angle is wrong"),
     (angle_unclipped, "clip it")],
)
def test_view_angle_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_view_angle(wrong)


def stub_raising(*args):
    raise NotImplementedError


@pytest.mark.parametrize("checker", [check_pixel_to_ray, check_project, check_view_angle])
def test_checkers_explain_an_untouched_stub(checker):
    with pytest.raises(AssertionError, match="NotImplementedError"):
        checker(stub_raising)
