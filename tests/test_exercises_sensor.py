"""The checkers of notebook 01's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest

from stair_lite.exercises.sensor import check_project, check_scale_intrinsics, check_view_angle
from stair_lite.geometry import Intrinsics, angular_distance


# ---- exercise 1: the same camera at another resolution -----------------------------------------
def scaled_ok(K, factor):
    out = K.astype(float).copy()
    out[:2] *= factor
    out[2] = [0, 0, 1]
    return out


def scaled_library(K, factor):
    big = Intrinsics(400, 300, K[0, 0], K[1, 1], K[0, 2], K[1, 2])
    return big.scaled(factor).K


def scaled_centres_at_integers(K, factor):
    out = scaled_ok(K, factor)
    out[:2, 2] = factor * (K[:2, 2] + 0.5) - 0.5
    return out


def scaled_focal_kept(K, factor):
    out = scaled_ok(K, factor)
    out[0, 0], out[1, 1] = K[0, 0], K[1, 1]
    return out


def scaled_centre_kept(K, factor):
    out = scaled_ok(K, factor)
    out[:2, 2] = K[:2, 2]
    return out


def scaled_inverse(K, factor):
    return scaled_ok(K, 1 / factor)


def scaled_everything(K, factor):
    return K * factor


def scaled_stub(K, factor):
    return None


def test_scale_intrinsics_accepts_correct():
    assert check_scale_intrinsics(scaled_ok)


def test_scale_intrinsics_accepts_the_library_where_its_sizes_are_whole():
    """Intrinsics.scaled rounds the image size; at factors that give whole sizes it is the exercise's answer."""
    rng = np.random.default_rng(0)
    for factor in (0.1, 0.2, 0.25, 0.5, 2.0):
        K = np.array([[rng.uniform(80, 400), 0, rng.uniform(20, 200)], [0, rng.uniform(80, 400), rng.uniform(20, 200)], [0, 0, 1]])
        assert np.allclose(scaled_library(K, factor), scaled_ok(K, factor))


@pytest.mark.parametrize(
    "wrong, hint",
    [(scaled_centres_at_integers, "integer"), (scaled_focal_kept, "field of view"), (scaled_centre_kept, "principal point"),
     (scaled_inverse, "divided"), (scaled_everything, "bottom-right"), (scaled_stub, "None")],
)
def test_scale_intrinsics_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_scale_intrinsics(wrong)


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


@pytest.mark.parametrize("checker", [check_scale_intrinsics, check_project, check_view_angle])
def test_checkers_explain_an_untouched_stub(checker):
    with pytest.raises(AssertionError, match="NotImplementedError"):
        checker(stub_raising)


def test_an_error_in_the_learners_code_is_named_with_the_arguments():
    def project_wrong_shapes(points, pose, K):
        return points @ pose, points[:, 2]  # (N, 3) @ (4, 4): numpy raises ValueError

    with pytest.raises(AssertionError, match=r"project_wrong_shapes raised ValueError(.|\n)*ndarray of shape \(\d+, 3\)"):
        check_project(project_wrong_shapes)
