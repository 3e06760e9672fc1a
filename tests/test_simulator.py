"""The simulator against an independent computation: trimesh/embree ray casting through the same pixels."""
import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

import stair_lite  # noqa: F401
from stair_lite.classes import BACKGROUND
from stair_lite.geometry import Intrinsics, pixel_rays, view_to_pose
from stair_lite.measurement import Measurement, back_project
from stair_lite.scenes import load_scene
from stair_lite.simulator import Simulator, target_only_image


@pytest.fixture(scope="module")
def scene():
    return load_scene("scene1")


@pytest.fixture(scope="module")
def sim(scene):
    return Simulator(scene, Intrinsics.from_fov(160, 120, 90))


def ray_cast(scene, intrinsics, pose):
    meshes = scene.labelled_meshes()
    merged = trimesh.util.concatenate([m for m, _ in meshes])
    face_class = np.concatenate([np.full(len(m.faces), c) for m, c in meshes])
    face_object = np.concatenate([np.full(len(m.faces), i - 1) for i, (m, _) in enumerate(meshes)])  # ground: -1
    origins, dirs = pixel_rays(intrinsics, pose)
    index_tri, index_ray, locations = merged.ray.intersects_id(origins, dirs, multiple_hits=False, return_locations=True)
    depth = np.zeros(len(origins))
    labels = np.zeros(len(origins), dtype=int)
    objects = np.full(len(origins), -1)
    hit_mask = np.zeros(len(origins), dtype=bool)
    depth[index_ray] = (locations - origins[index_ray]) @ pose[:3, 2]  # z-depth
    labels[index_ray] = face_class[index_tri]
    objects[index_ray] = face_object[index_tri]
    hit_mask[index_ray] = True
    shape = (intrinsics.height, intrinsics.width)
    return depth.reshape(shape), labels.reshape(shape), hit_mask.reshape(shape), objects.reshape(shape)


@pytest.mark.parametrize("view", [(np.pi / 2, 0.0), (0.6, 0.8), (0.12, 3.5)])
def test_depth_and_labels_match_ray_casting(scene, sim, view):
    pose = view_to_pose(*view)
    m = sim.render(pose)
    depth, labels, hit, _ = ray_cast(scene, sim.intrinsics, pose)
    assert np.array_equal(m.depth > 0, hit)
    # Exact labels and depth, except at a handful of pixels whose centre grazes a triangle edge,
    # where the two rasterisers may pick different triangles.
    agree = m.labels == labels
    assert np.mean(~agree) < 1e-3
    error = np.abs(m.depth - depth)[hit]
    assert np.mean(error > 2e-3) < 1e-3
    assert np.median(error) < 1e-4


@pytest.mark.parametrize("view", [(np.pi / 2, 0.0), (0.3, 2.0)])
def test_objects_seen_match_ray_casting(scene, sim, view):
    """The object each pixel sees first (one segmentation pass with an id per object) is the object of the
    triangle a ray through that pixel hits first, except at a handful of pixels on triangle edges."""
    _, _, _, objects = ray_cast(scene, sim.intrinsics, view_to_pose(*view))
    seen = sim.objects_seen(*view)
    assert set(np.unique(seen)) <= set(range(-1, len(scene.object_meshes))) and (seen >= 0).sum() > 100
    assert np.mean(seen != objects) < 1e-3


def test_images_have_the_documented_types(sim):
    m = sim.render_view(0.8, 1.0)
    assert m.rgb.dtype == np.float32 and m.rgb.shape == (120, 160, 3) and 0 <= m.rgb.min() and m.rgb.max() <= 1
    assert m.depth.dtype == np.float32 and m.depth.min() >= 0
    assert np.issubdtype(m.labels.dtype, np.integer)
    assert set(np.unique(m.labels)) <= set(range(7))
    # nothing hit: white (pixels next to an object may blend with it: the colour pass is anti-aliased)
    empty = m.depth == 0
    interior = empty[1:-1, 1:-1] & empty[:-2, 1:-1] & empty[2:, 1:-1] & empty[1:-1, :-2] & empty[1:-1, 2:]
    assert interior.sum() > 100
    np.testing.assert_array_equal(m.rgb[1:-1, 1:-1][interior], 1.0)


def test_colour_is_view_independent(scene):
    """The same surface point has the same colour from two views (baked lighting, no specular)."""
    sim = Simulator(scene)
    a, b = sim.render_view(0.9, 0.3), sim.render_view(0.5, 1.1)
    pa, ca, la = back_project(a)
    pb, cb, lb = back_project(b)
    tree = cKDTree(pb)
    d, j = tree.query(pa)
    close = (d < 2e-3) & (la != BACKGROUND)
    assert close.sum() > 100
    assert np.median(np.abs(ca[close] - cb[j[close]]).max(axis=1)) < 0.02


def test_back_projection_lands_on_the_meshes(scene, sim):
    m = sim.render_view(0.7, 2.0)
    points, _, labels = back_project(m)
    ground = labels == BACKGROUND
    assert ground.any() and (~ground).any()
    np.testing.assert_allclose(points[ground, 2], 0.0, atol=1e-3)  # the ground's top is the plane z = 0
    objects = trimesh.util.concatenate(scene.object_meshes)
    surface, _ = trimesh.sample.sample_surface_even(objects, 300_000, seed=0)
    distance, _ = cKDTree(surface).query(points[~ground])
    assert np.percentile(distance, 99) < 5e-3  # the surface samples are about 3 mm apart


def test_renders_are_deterministic(sim):
    a, b = sim.render_view(0.4, 0.4), sim.render_view(0.4, 0.4)
    np.testing.assert_array_equal(a.rgb, b.rgb)
    np.testing.assert_array_equal(a.labels, b.labels)


def test_several_simulators_share_one_renderer():
    s1 = Simulator(load_scene("scene2"), Intrinsics.from_fov(64, 64))
    s2 = Simulator(load_scene("scene3"), Intrinsics.from_fov(32, 32))
    del s1
    assert s2.render_view(1.0, 0.0).rgb.shape == (32, 32, 3)


def test_target_only_image_whitens_other_pixels(sim):
    m = sim.render_view(0.5, 0.5)
    gt = target_only_image(m, ["car"])
    car = m.labels == 1
    assert car.any() and (~car).any()
    np.testing.assert_array_equal(gt[~car], 1.0)
    np.testing.assert_array_equal(gt[car], m.rgb[car])


def test_bad_pose_is_rejected(sim):
    with pytest.raises(ValueError, match="4x4"):
        sim.render(np.eye(3))


def test_measurement_validation_names_the_problem():
    k = Intrinsics.from_fov(4, 3)
    good = dict(rgb=np.zeros((3, 4, 3), np.float32), depth=np.ones((3, 4), np.float32), labels=np.zeros((3, 4), int), pose=np.eye(4), intrinsics=k)
    Measurement(**good)
    with pytest.raises(ValueError, match=r"rgb has shape \(3, 5, 3\)"):
        Measurement(**{**good, "rgb": np.zeros((3, 5, 3))})
    with pytest.raises(ValueError, match="NaN"):
        Measurement(**{**good, "depth": np.full((3, 4), np.nan)})
    with pytest.raises(ValueError, match="depth must be >= 0"):
        Measurement(**{**good, "depth": -np.ones((3, 4))})
    with pytest.raises(ValueError, match="class range"):
        Measurement(**{**good, "labels": np.full((3, 4), 9)})


def test_other_intrinsics_apply_to_one_render_only(sim):
    small = Intrinsics.from_fov(20, 10)
    assert sim.render_view(0.5, 0.5, small).rgb.shape == (10, 20, 3)
    assert sim.render_view(0.5, 0.5).rgb.shape == (120, 160, 3)  # back to the simulator's own camera
