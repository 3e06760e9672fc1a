import numpy as np
import pytest

from stair_lite.geometry import (
    MIN_ELEVATION,
    Intrinsics,
    angular_distance,
    fibonacci_hemisphere,
    local_views,
    look_at,
    pixel_rays,
    pose_to_view,
    random_hemisphere,
    test_views,
    view_spread,
    view_to_pose,
    views_to_directions,
)


def test_default_intrinsics_90_degrees():
    k = Intrinsics.from_fov()
    assert (k.width, k.height) == (400, 400)
    assert k.fx == pytest.approx(200.0) and k.cx == 200.0 and k.cy == 200.0
    assert np.degrees(k.fov_y_rad) == pytest.approx(90.0)


@pytest.mark.parametrize("w,h", [(0, 400), (400, -1), (10.5, 10)])
def test_bad_image_size_is_named(w, h):
    with pytest.raises(ValueError, match="positive"):
        Intrinsics.from_fov(w, h)


@pytest.mark.parametrize("fov", [0.0, 180.0, -5.0, 200.0])
def test_bad_fov_is_named(fov):
    with pytest.raises(ValueError, match=r"field of view.*\(0, 180\)"):
        Intrinsics.from_fov(fov_deg=fov)


def test_scaled_intrinsics_keep_the_field_of_view():
    k = Intrinsics.from_fov(400, 400, 90).scaled(0.2)
    assert (k.width, k.height) == (80, 80)
    assert np.degrees(k.fov_y_rad) == pytest.approx(90.0)


@pytest.mark.parametrize("el,az", [(0.3, 0.0), (1.0, 2.0), (MIN_ELEVATION, 5.0), (np.pi / 2, 0.0), (np.pi / 2, 1.3)])
def test_pose_looks_at_origin_and_is_a_rotation(el, az):
    pose = view_to_pose(el, az)
    r, t = pose[:3, :3], pose[:3, 3]
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0)
    assert np.linalg.norm(t) == pytest.approx(2.0)
    np.testing.assert_allclose(r[:, 2], -t / np.linalg.norm(t), atol=1e-12)  # z forward hits the origin
    # image "down" (camera +y) points downwards in the world, or is horizontal at the top view
    assert r[2, 1] <= 1e-9


def test_view_pose_round_trip():
    rng = np.random.default_rng(0)
    for el, az in random_hemisphere(50, rng):
        el2, az2 = pose_to_view(view_to_pose(el, az))
        assert el2 == pytest.approx(el, abs=1e-9)
        assert np.cos(az2 - az) == pytest.approx(1.0, abs=1e-9)


def test_top_view_is_defined_and_continuous():
    top = view_to_pose(np.pi / 2, 0.0)
    np.testing.assert_allclose(top[:3, 3], [0, 0, 2], atol=1e-12)
    np.testing.assert_allclose(top[:3, 2], [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(-top[:3, 1], [-1, 0, 0], atol=1e-12)  # image up is world -x
    near_top = view_to_pose(np.pi / 2 - 1e-4, 0.0)
    np.testing.assert_allclose(near_top[:3, :3], top[:3, :3], atol=1e-3)


def test_look_at_rejects_degenerate_input():
    with pytest.raises(ValueError, match="coincides"):
        look_at([0, 0, 0])
    with pytest.raises(ValueError, match="parallel"):
        look_at([0, 0, 2])


def test_elevation_outside_hemisphere_is_named():
    with pytest.raises(ValueError, match="elevation"):
        view_to_pose(-0.3, 0.0)


def test_area_uniform_sampler_has_uniform_sine_of_elevation():
    views = random_hemisphere(20000, np.random.default_rng(1))
    s = np.sin(views[:, 0])
    hist, _ = np.histogram(s, bins=10, range=(np.sin(MIN_ELEVATION), 1.0))
    np.testing.assert_allclose(hist / len(s), 0.1, atol=0.01)
    hist_az, _ = np.histogram(views[:, 1], bins=8, range=(0, 2 * np.pi))
    np.testing.assert_allclose(hist_az / len(s), 1 / 8, atol=0.01)
    assert views[:, 0].min() >= MIN_ELEVATION


def test_samplers_are_deterministic_given_a_seed():
    a = random_hemisphere(10, np.random.default_rng(7))
    b = random_hemisphere(10, np.random.default_rng(7))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(local_views(a[0], 5, np.random.default_rng(3)), local_views(a[0], 5, np.random.default_rng(3)))


def test_fibonacci_views_cover_the_hemisphere_evenly():
    views = fibonacci_hemisphere(100)
    # equal-area rings: sin(elevation) is evenly spaced
    np.testing.assert_allclose(np.diff(np.sin(views[:, 0])), 0.01, atol=1e-9)
    # coverage: every direction of a dense random set is close to some view
    probe = random_hemisphere(5000, np.random.default_rng(2))
    nearest = angular_distance(probe, views).min(axis=1)
    assert nearest.max() < np.radians(15)
    assert len(test_views()) == 100


def test_local_views_lie_in_the_requested_ring():
    centre = np.array([0.6, 1.0])
    views = local_views(centre, 200, np.random.default_rng(4), 0.1, 0.5)
    d = angular_distance(views, centre[None])[:, 0]
    assert d.min() >= 0.1 - 1e-9 and d.max() <= 0.5 + 1e-9
    assert views[:, 0].min() >= MIN_ELEVATION
    low = local_views(np.array([0.02, 0.0]), 100, np.random.default_rng(5))
    assert low[:, 0].min() >= MIN_ELEVATION  # samples below the horizon are redrawn


def test_pixel_rays_have_unit_camera_z_and_hit_the_principal_point():
    k = Intrinsics.from_fov(4, 4, 90)
    pose = view_to_pose(0.7, 0.4)
    origins, dirs = pixel_rays(k, pose)
    assert dirs.shape == (16, 3)
    np.testing.assert_allclose(dirs @ pose[:3, 2], 1.0, atol=1e-12)  # camera-frame z = 1: t is z-depth
    np.testing.assert_allclose(origins, np.broadcast_to(pose[:3, 3], origins.shape))
    # the four centre pixels are symmetric about the optical axis
    centre = dirs.reshape(4, 4, 3)[1:3, 1:3].reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(centre, pose[:3, 2], atol=1e-12)
    assert np.allclose(views_to_directions(np.array([[np.pi / 2, 0]])), [[0, 0, 1]])


def test_view_spread_is_the_mean_angle_between_pairs_and_ignores_a_turn_about_the_vertical():
    assert np.isclose(view_spread(np.array([[0.0, 0.0], [0.0, np.pi]])), np.pi)           # opposite on the horizon
    top_and_two = np.array([[np.pi / 2, 0.0], [0.0, 0.0], [0.0, np.pi / 2]])                # three right angles
    assert np.isclose(view_spread(top_and_two), np.pi / 2)
    views = fibonacci_hemisphere(10)
    turned = views + np.array([0.0, 1.234])
    assert np.isclose(view_spread(views), view_spread(turned))
    assert view_spread(views[:2]) != view_spread(views)                                     # not a constant
    with pytest.raises(ValueError, match="at least two views"):
        view_spread(views[:1])


def test_importing_the_package_runs_openblas_on_one_thread():
    """cores.py: beside torch's spinning threads, pixel_rays' product of a 400 x 400 view on two BLAS threads took
    about 100x as long as on one. Both orders: numpy and scipy loaded before the package (a notebook), and after it
    (the command line imports the package first), in a fresh interpreter without the variables OpenBLAS reads its thread count from."""
    import os
    import subprocess
    import sys

    code = ("{}import stair_lite, numpy, scipy.linalg; from threadpoolctl import threadpool_info; "
            "print(sorted({{lib['num_threads'] for lib in threadpool_info() if lib['internal_api'] == 'openblas'}}))")
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")}
    for first in ("", "import numpy, scipy.linalg; "):
        out = subprocess.run([sys.executable, "-c", code.format(first)], env=env, capture_output=True, text=True, check=True)
        assert out.stdout.strip() == "[1]", (first, out.stdout, out.stderr)
