from dataclasses import replace

import numpy as np
import pytest
import torch
import trimesh

import stair_lite  # noqa: F401
from stair_lite.config import ExplicitConfig, FieldConfig, get_preset
from scipy.spatial import cKDTree

from stair_lite.evaluation import Evaluator, extract_mesh, f1_column, mesh_scores, mesh_scores_from_points, psnr, sample_surface
from stair_lite.explicit import ExplicitMap
from stair_lite.lattice import CUBE_BOUND, Lattice
from stair_lite.maps import ImplicitMap
from stair_lite.scenes import load_scene
from stair_lite.simulator import Simulator, target_only_image


def test_psnr_closed_form():
    a = np.zeros((4, 4, 3))
    assert psnr(a, a + 0.1) == pytest.approx(20.0)
    assert psnr(a, a) == float("inf")


class SphereField:
    """A stand-in field: occupancy 1 inside a sphere, class 1 (car) there, background elsewhere."""

    cfg = FieldConfig(grid_resolution=8)
    lattice = Lattice(8)
    device = torch.device("cpu")

    def __init__(self, centre, radius):
        self.centre, self.radius = torch.tensor(centre), radius

    def query(self, x):
        inside = ((x - self.centre).norm(dim=1) < self.radius).float()
        sem = torch.zeros(len(x), 7)
        sem[:, 1], sem[:, 0] = inside, 1 - inside
        return {"occ": inside, "sem": sem}


def test_extracted_mesh_sits_on_the_occupied_boundary():
    field = SphereField((0.2, -0.1, 0.6), 0.4)
    mesh = extract_mesh(field, resolution=96, targets=(1,))
    spacing = 2 * CUBE_BOUND / 95
    r = np.linalg.norm(mesh.vertices - np.array([0.2, -0.1, 0.6]), axis=1)
    assert np.all(np.abs(r - 0.4) < spacing)
    assert extract_mesh(field, resolution=64, targets=(2,)) is None  # no chair anywhere


def test_mesh_scores_of_identical_and_shifted_meshes():
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.3)
    same = mesh_scores(sphere, sphere, 20000, 0.01)
    assert same.precision > 0.99 and same.completeness > 0.99 and same.f1 > 0.99
    shifted = sphere.copy()
    shifted.apply_translation((0.05, 0, 0))
    far = mesh_scores(shifted, sphere, 20000, 0.01)
    assert far.f1 < 0.3 and far.chamfer > 0.01
    empty = mesh_scores(None, sphere, 1000, 0.01)
    assert (empty.precision, empty.completeness, empty.f1) == (0.0, 0.0, 0.0)


def test_evaluator_rejects_targets_not_in_the_scene():
    sim = Simulator(load_scene("scene1"))
    with pytest.raises(ValueError, match="do not occur in scene"):
        Evaluator(sim, ["airplane"], get_preset("lite"))


def test_skipping_empty_space_matches_the_exact_render():
    from dataclasses import replace

    from stair_lite.config import EvalConfig, TrainConfig
    from stair_lite.geometry import fibonacci_hemisphere, view_to_pose
    from stair_lite.rendering import build_skip_grid, render_target_views

    preset = replace(get_preset("lite"), field=FieldConfig(grid_resolution=32, rgb_hidden=(32, 32)),
                     explicit=ExplicitConfig(resolution=32),
                     train=TrainConfig(rays_new=512, rays_replay=512, iterations_per_view=40),
                     eval=EvalConfig(n_test_views=4, image_scale=0.2, mesh_resolution=64, mesh_points=20000,
                                     render_samples=64))
    scene = load_scene("scene1")
    sim = Simulator(scene)
    implicit = ImplicitMap.from_preset(preset, seed=0)
    for el, az in fibonacci_hemisphere(3, azimuth_offset=0.3):
        implicit.integrate(sim.render(view_to_pose(el, az)))
    evaluator = Evaluator(sim, scene.targets, preset)
    render_cfg = replace(preset.render, n_samples=preset.eval.render_samples)  # what the evaluation renders with
    field, views = implicit.field, (evaluator.intrinsics, evaluator.poses, render_cfg, scene.targets)
    fast = render_target_views(field, *views, skip=build_skip_grid(field, scene.targets))
    exact = render_target_views(field, *views)
    for f, e, gt in zip(fast, exact, evaluator.gt_images):
        assert np.mean(np.abs(f - e).max(axis=-1) > 1e-3) < 2e-3
        assert psnr(f, gt) == pytest.approx(psnr(e, gt), abs=0.05)
    from stair_lite.evaluation import GROUND_CUT_Z
    skip = build_skip_grid(field, scene.targets)
    both = list(zip(*implicit.target_only_renders(evaluator.intrinsics, evaluator.poses, scene.targets, GROUND_CUT_Z)))
    separate = (fast, render_target_views(field, *views, skip=skip.above(GROUND_CUT_Z)))  # one render each
    for combined, alone in zip(both, separate):
        for a, b in zip(combined, alone):
            np.testing.assert_allclose(a, b, atol=1e-5)
    assert any(not np.allclose(a, b) for a, b in zip(*both))  # the cut removes something in these views
    result = evaluator.evaluate(implicit)
    assert result["psnr"] > 12 and 0 <= result["f1"] <= 1 and result["mesh"] is not None
    # the target mesh, evaluated only where the skip grid keeps cells, is the mesh of the whole lattice
    exact_mesh = extract_mesh(field, preset.eval.mesh_resolution, targets=scene.targets)
    np.testing.assert_array_equal(implicit.target_mesh(scene.targets).vertices, exact_mesh.vertices)


def test_evaluation_renders_take_their_samples_per_ray_from_the_eval_config():
    """``EvalConfig.render_samples`` sets the evaluation renders' samples per ray, and it changes what they show."""
    from dataclasses import replace

    from stair_lite.evaluation import GROUND_CUT_Z
    from stair_lite.geometry import TOP_VIEW, Intrinsics, view_to_pose
    from stair_lite.rendering import build_skip_grid, render_target_views_and_cut

    preset, scene = get_preset("smoke"), load_scene("scene1")
    sim, K = Simulator(scene), Intrinsics.from_fov().scaled(0.1)
    poses = [view_to_pose(0.6, azimuth) for azimuth in (0.5, 2.5)]
    renders = {}
    for samples in (32, 96):
        implicit = ImplicitMap.from_preset(replace(preset, eval=replace(preset.eval, render_samples=samples)), seed=0)
        implicit.integrate(sim.render_view(*TOP_VIEW))
        renders[samples] = list(implicit.target_only_renders(K, poses, scene.targets, GROUND_CUT_Z))
    field = implicit.field  # trained the same way as the first map (same seed, same view)
    direct = render_target_views_and_cut(field, K, poses, replace(preset.render, n_samples=96), scene.targets,
                                         build_skip_grid(field, scene.targets), GROUND_CUT_Z)
    for mine, expected in zip(renders[96], direct):
        for a, b in zip(mine, expected):
            np.testing.assert_allclose(a, b, atol=1e-6)
    assert any(not np.allclose(a[0], b[0]) for a, b in zip(renders[32], renders[96]))


def test_target_renders_match_the_plain_renders_also_where_kept_cells_lie_behind_the_camera():
    """The evaluation's renders (sample windows per ray, only kept samples composited) are the plain renders of
    ``render_target_views`` with the skip grid and with its cut, from a hemisphere view and from a camera inside the
    cube, where a kept cell lies behind the camera and the kept cells' box bounds the rays instead."""
    from stair_lite.evaluation import GROUND_CUT_Z
    from stair_lite.geometry import TOP_VIEW, Intrinsics, view_to_pose
    from stair_lite.rendering import build_skip_grid, render_target_views, render_target_views_and_cut

    preset, scene = get_preset("smoke"), load_scene("scene1")
    implicit = ImplicitMap.from_preset(preset, seed=0)
    implicit.integrate(Simulator(scene).render_view(*TOP_VIEW))
    field, K, cfg = implicit.field, Intrinsics.from_fov().scaled(0.1), preset.render
    skip = build_skip_grid(field, scene.targets)
    poses = [view_to_pose(0.6, 0.5), view_to_pose(0.3, 2.0, radius=0.4)]
    assert skip.ray_windows(K, poses[0]) is not None and skip.ray_windows(K, poses[1]) is None
    both = list(zip(*render_target_views_and_cut(field, K, poses, cfg, scene.targets, skip, GROUND_CUT_Z)))
    for combined, grid in zip(both, (skip, skip.above(GROUND_CUT_Z))):
        for a, b in zip(combined, render_target_views(field, K, poses, cfg, scene.targets, skip=grid)):
            np.testing.assert_allclose(a, b, atol=1e-5)
            assert (b < 1).any()  # each view shows a target


def small_eval_preset():
    from dataclasses import replace

    from stair_lite.config import EvalConfig

    return replace(get_preset("lite"), field=FieldConfig(grid_resolution=32, rgb_hidden=(32, 32)),
                   explicit=ExplicitConfig(resolution=32),
                   eval=EvalConfig(n_test_views=6, image_scale=0.2, mesh_resolution=64, mesh_points=20000))


def test_clean_ground_truth_differs_only_where_other_objects_hide_a_target(tmp_path):
    """Without other objects the two ground truths agree; in scene 1 the clean one shows more target."""
    from dataclasses import replace

    from stair_lite.scenes import build_scene, load_scene_spec, save_scene_spec

    preset = small_eval_preset()
    spec = load_scene_spec("scene1")
    path = save_scene_spec(replace(spec, name="cars_only", objects=tuple(o for o in spec.objects if o.cls in spec.targets)),
                           tmp_path / "cars_only.json")
    alone = Evaluator(Simulator(build_scene(load_scene_spec(path))), spec.targets, preset)
    for visible, clean in zip(alone.gt_images, alone.gt_alone_images):
        assert np.array_equal(visible, clean)
    full = Evaluator(Simulator(load_scene("scene1")), spec.targets, preset)
    shown = lambda images: sum(int((g < 1).any(axis=-1).sum()) for g in images)
    assert shown(full.gt_alone_images) > shown(full.gt_images)


def test_ground_truth_kept_at_eight_bits_is_the_rendered_image_exactly():
    """The evaluator keeps its ground-truth images at 8 bits (the renderer's colour depth): nothing is lost."""
    preset = small_eval_preset()
    scene = load_scene("scene1")
    sim = Simulator(scene)
    evaluator = Evaluator(sim, scene.targets, preset)
    for pose, stored in zip(evaluator.poses, evaluator.gt_images):
        rendered = target_only_image(sim.render(pose, evaluator.intrinsics), scene.targets)
        assert stored.dtype == np.float32 and np.array_equal(stored, rendered)


def test_clean_psnr_of_an_empty_map_is_the_blank_render_psnr():
    """An untrained field renders no target (every sample's class argmax is background), so both PSNRs
    are those of an all-white image; the clean one averages over the views that show a target."""
    preset = small_eval_preset()
    scene = load_scene("scene1")
    evaluator = Evaluator(Simulator(scene), scene.targets, preset)
    result = evaluator.evaluate(ImplicitMap.from_preset(preset, seed=0))
    blank = [psnr(np.ones_like(g), g) for g in evaluator.gt_alone_images]
    assert evaluator.views_with_targets and result["mesh"] is None
    assert result["psnr_clean"] == pytest.approx(np.mean([blank[i] for i in evaluator.views_with_targets]))
    assert result["psnr"] == pytest.approx(np.mean([psnr(np.ones_like(g), g) for g in evaluator.gt_images]))


def test_above_drops_only_the_cells_below_the_cut():
    from stair_lite.evaluation import GROUND_CUT_Z
    from stair_lite.rendering import SkipGrid

    lattice = Lattice(16)
    cut = SkipGrid(torch.ones(16**3, dtype=torch.bool), lattice).above(GROUND_CUT_Z).keep.view(16, 16, 16)  # [z, y, x]
    z = np.linspace(-CUBE_BOUND, CUBE_BOUND, 16)
    assert np.array_equal(cut[:, 0, 0].numpy(), z >= GROUND_CUT_Z) and cut[:, 3, 7].equal(cut[:, 0, 0])
    points = lattice.points()
    assert torch.equal(cut.reshape(-1), points[:, 2] >= GROUND_CUT_Z)  # the flat order is the lattice's


def test_f1_at_more_thresholds_counts_points_within_each_distance():
    """Two parallel planes 3 cm apart: every point is 3 cm from the other plane, so F1 is 0 at 1 and 2 cm
    and 1 at 5 cm; the thresholds share one distance computation with the paper's 1 cm score."""
    plane = trimesh.creation.box(extents=(0.6, 0.6, 1e-4))
    lifted = plane.copy()
    lifted.apply_translation((0, 0, 0.03))
    pred, gt = sample_surface(lifted, 5000, 1), sample_surface(plane, 5000, 0)
    scores = mesh_scores_from_points(pred, cKDTree(gt), gt, 0.01, (0.02, 0.05))
    assert scores.f1 == 0.0 and scores.f1_at[0.02] == 0.0 and scores.f1_at[0.05] > 0.99
    assert f1_column(0.02) == "f1_2cm" and f1_column(0.05) == "f1_5cm"
    assert mesh_scores_from_points(np.zeros((0, 3)), cKDTree(gt), gt, 0.01, (0.05,)).f1_at == {0.05: 0.0}


def test_occupied_share_below_counts_the_phantom_under_the_ground():
    """A field that fills everything below z = -0.5 has that share of the sub-ground lattice occupied; a
    voxel map that observed nothing has none (unknown is p = 0.5, not occupied)."""
    preset = get_preset("smoke")
    implicit = ImplicitMap.from_preset(preset)
    with torch.no_grad():  # features that saturate the occupancy below z = -0.5
        points = implicit.field.lattice.points()
        implicit.field.grid_occ[points[:, 2] < -0.5] = 1e3
        implicit.field.reached.fill_(True)  # as if measurements had reached every cell (FieldConfig.reached_only)
        implicit.field.occ_mlp[-1].bias.fill_(0.0)
    lattice_z = implicit.field.lattice.axis()
    below = lattice_z[lattice_z < -0.05]
    expected = float((below < -0.5).float().mean())
    share = implicit.occupied_share_below(-0.05)
    assert 0.3 < expected and abs(share - expected) < 0.5 / len(below), (share, expected)
    assert ExplicitMap.from_preset(preset).occupied_share_below(-0.05) == 0.0


def test_occupied_share_below_queries_only_the_reached_vertices_and_counts_as_the_dense_query():
    """Occupancy only where a ray reached: the vertices no ray reached are not queried, and the share is the dense
    query's to the last bit; with ``reached_only`` the head's high occupancy at an unreached vertex counts for nothing."""
    preset = get_preset("smoke")
    for reached_only in (True, False):
        preset_here = replace(preset, field=replace(preset.field, reached_only=reached_only))
        implicit = ImplicitMap.from_preset(preset_here)
        field = implicit.field
        with torch.no_grad():
            points = field.lattice.points()
            field.grid_occ[points[:, 2] < -0.3] = 1e3  # the head alone fills the volume below z = -0.3
            field.occ_mlp[-1].bias.fill_(0.0)
            field.reached.copy_(torch.rand(len(points), generator=torch.Generator().manual_seed(0)) < 0.5)
        below = points[points[:, 2] < -0.05]
        dense = float((field.query(below)["occ"] > 0.5).float().mean())
        queried = []
        query = field.query
        field.query = lambda x, **kw: (queried.append(len(x)), query(x, **kw))[1]
        assert implicit.occupied_share_below(-0.05) == dense
        assert queried == [int((field.reached[points[:, 2] < -0.05]).sum()) if reached_only else len(below)]
        assert dense > 0.1  # the check has occupied vertices to count


def test_the_point_tree_finds_the_same_nearest_distances_as_scipys_default_tree():
    """``point_tree`` changes only how the search runs: on a shell and points inside, outside and on it (the slow case
    of the default tree: nearest samples far away), the distances equal a default cKDTree's bit for bit."""
    from stair_lite.evaluation import point_tree

    rng = np.random.default_rng(0)
    shell = rng.normal(size=(20000, 3))
    shell = 0.4 * shell / np.linalg.norm(shell, axis=1, keepdims=True)
    shell = shell[shell[:, 2] > -0.1]  # a shell open at the bottom, as a map that has not seen an object's underside
    queries = np.concatenate([shell[:500] * rng.uniform(0.0, 2.0, size=(500, 1)), rng.uniform(-1, 1, size=(500, 3))])
    ours, _ = point_tree(shell).query(queries)
    default, _ = cKDTree(shell).query(queries)
    np.testing.assert_array_equal(ours, default)


def test_mesh_scores_in_spatial_order_are_the_scores_of_plain_queries():
    """The scores query the points in ``spatial_order`` against trees built on sorted points: the same precision,
    completeness, F1 and chamfer distance, bit for bit, as scipy's default tree queried point by point in the
    samples' own order (the chamfer mean sums the distances in that order)."""
    from stair_lite.evaluation import f1_score, mesh_scores_from_points, point_tree, spatial_order

    rng = np.random.default_rng(1)
    gt = rng.normal(size=(30000, 3))
    gt = 0.4 * gt / np.linalg.norm(gt, axis=1, keepdims=True)
    pred = gt[rng.permutation(len(gt))[:20000]] + rng.normal(scale=0.01, size=(20000, 3))
    pred = pred[pred[:, 2] > -0.2]  # a side not reconstructed: far nearest samples from the ground truth's side
    order = spatial_order(pred, cell=0.05)
    assert sorted(order) == list(range(len(pred)))
    cells = np.floor((pred[order] - pred.min(axis=0)) / 0.05).astype(int)
    assert (np.diff(cells[:, 2]) >= 0).all()  # layer by layer
    scores = mesh_scores_from_points(pred, point_tree(gt), gt, 0.01, (0.02, 0.05))
    d_pred, d_gt = cKDTree(gt).query(pred)[0], cKDTree(pred).query(gt)[0]
    assert scores.chamfer == float((d_pred.mean() + d_gt.mean()) / 2)
    assert (scores.precision, scores.completeness) == (float(np.mean(d_pred < 0.01)), float(np.mean(d_gt < 0.01)))
    assert scores.f1 == f1_score(scores.precision, scores.completeness) and 0 < scores.completeness < 0.9
    assert scores.f1_at == {t: f1_score(float(np.mean(d_pred < t)), float(np.mean(d_gt < t))) for t in (0.02, 0.05)}
    # with the ground truth's order given (an evaluator computes it once): the same scores
    assert mesh_scores_from_points(pred, point_tree(gt), gt, 0.01, (0.02, 0.05), spatial_order(gt)) == scores


def test_a_tree_of_no_points_answers_like_scipys():
    from stair_lite.evaluation import nearest_distances, point_tree, spatial_order

    assert len(spatial_order(np.zeros((0, 3)))) == 0
    assert point_tree(np.zeros((0, 3))).n == 0
    assert len(nearest_distances(point_tree(np.ones((3, 3))), np.zeros((0, 3)))) == 0


def test_nearest_distances_come_back_in_the_queries_order():
    """Queried in spatial order, the distances are returned query by query: each equals a plain query's."""
    from stair_lite.evaluation import nearest_distances, point_tree

    rng = np.random.default_rng(2)
    points, queries = rng.uniform(-1, 1, size=(5000, 3)), rng.uniform(-1.2, 1.2, size=(3000, 3))
    np.testing.assert_array_equal(nearest_distances(point_tree(points), queries), cKDTree(points).query(queries)[0])
