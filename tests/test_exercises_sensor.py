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


# ---- the look-at pose ----------------------------------------------------------------------------
from stair_lite.exercises.sensor import check_back_project, check_view_to_pose  # noqa: E402
from stair_lite.geometry import view_to_pose  # noqa: E402
from stair_lite.measurement import back_project  # noqa: E402


def pose_from_axes(elevation, azimuth, radius, flip_forward=False, flip_right=False, transpose=False, centre=True):
    t = radius * np.array([np.cos(azimuth) * np.cos(elevation), np.sin(azimuth) * np.cos(elevation), np.sin(elevation)])
    z = -t / np.linalg.norm(t)
    up = np.array([0.0, 0.0, 1.0])
    if np.pi / 2 - elevation < 1e-6:
        up = -np.array([np.cos(azimuth), np.sin(azimuth), 0.0])
    x = np.cross(up, z) if flip_right else np.cross(z, up)
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, -z if flip_forward else z], axis=1)
    pose = np.eye(4)
    pose[:3, :3] = R.T if transpose else R
    pose[:3, 3] = t if centre else 0.0
    return pose


def test_view_to_pose_accepts_the_library_and_a_hand_written_one():
    assert check_view_to_pose(view_to_pose)
    assert check_view_to_pose(pose_from_axes)


@pytest.mark.parametrize("wrong, hint", [
    (dict(flip_forward=True), "looks away from the origin"),
    (dict(flip_right=True), "x points left"),
    (dict(transpose=True), "transposed"),
    (dict(centre=False), "not zero"),
])
def test_view_to_pose_rejects_plausible_mistakes(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_view_to_pose(lambda el, az, r: pose_from_axes(el, az, r, **wrong))


def test_view_to_pose_rejects_swapped_angles():
    with pytest.raises(AssertionError, match="camera centre is off|view_to_pose is wrong"):
        check_view_to_pose(lambda el, az, r: view_to_pose(el, az, r) if el > 1.5 else pose_from_axes(az % 1.5, el, r))


# ---- back-projection -----------------------------------------------------------------------------
def back_project_by_hand(m, half=0.5, swap=False, as_range=False, inverse=False, keep_misses=False):
    k = m.intrinsics
    v, u = np.mgrid[0 : k.height, 0 : k.width]
    if swap:
        u, v = v, u
    cam = np.stack([(u + half - k.cx) / k.fx, (v + half - k.cy) / k.fy, np.ones(u.shape)], axis=-1).reshape(-1, 3)
    if as_range:
        cam = cam / np.linalg.norm(cam, axis=1, keepdims=True)
    depth = m.depth.reshape(-1)
    hit = np.ones_like(depth, bool) if keep_misses else depth > 0
    cam = cam[hit] * depth[hit, None]
    world = (cam - m.pose[:3, 3]) @ m.pose[:3, :3] if inverse else cam @ m.pose[:3, :3].T + m.pose[:3, 3]
    return world, m.labels.reshape(-1)[hit]


def test_back_project_accepts_the_library_and_a_hand_written_one():
    assert check_back_project(lambda m: (back_project(m)[0], back_project(m)[2]))
    assert check_back_project(back_project_by_hand)


@pytest.mark.parametrize("wrong, hint", [
    (dict(half=0.0), "half a pixel"),
    (dict(as_range=True), "z-depth, not range"),
    (dict(swap=True), "swapped|wrong"),
    (dict(inverse=True), "inverse pose"),
    (dict(keep_misses=True), "depth 0"),
])
def test_back_project_rejects_plausible_mistakes(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_back_project(lambda m: back_project_by_hand(m, **wrong))


def test_back_project_rejects_wrong_labels_and_a_stub():
    with pytest.raises(AssertionError, match="labels"):
        check_back_project(lambda m: (back_project(m)[0], back_project(m)[2][::-1]))
    with pytest.raises(AssertionError, match="pair"):
        check_back_project(lambda m: back_project(m)[0])
