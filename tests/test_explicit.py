import numpy as np
import pytest
import torch

import stair_lite  # noqa: F401
from stair_lite.config import ExplicitConfig
from stair_lite.explicit import ExplicitMap, logit
from stair_lite.geometry import Intrinsics, pixel_rays, view_to_pose
from stair_lite.measurement import Measurement, back_project
from stair_lite.scenes import load_scene
from stair_lite.simulator import Simulator

K = Intrinsics.from_fov(40, 40)


def flat_measurement(depth_value=1.5, label=2):
    """Top view of a horizontal wall of class ``label`` at z = 2 - depth (every pixel hits it)."""
    pose = view_to_pose(np.pi / 2, 0.0)
    depth = np.full((40, 40), depth_value, np.float32)
    return Measurement(np.full((40, 40, 3), 0.25, np.float32), depth, np.full((40, 40), label), pose, K)


def test_endpoints_become_occupied_and_labelled_and_rays_free():
    emap = ExplicitMap(ExplicitConfig(resolution=32, pixel_stride=1))
    m = flat_measurement()
    emap.integrate(m)
    points, _, _ = back_project(m)
    index, inside = emap.voxel_index(torch.as_tensor(points, dtype=torch.float32))
    assert inside.all()
    p = emap.probability
    assert torch.allclose(p[index], torch.tensor(0.7))  # one hit: prob_hit
    assert torch.all(emap.labels[index] == 2)
    assert torch.allclose(emap.colours[index], torch.tensor(0.25))
    camera = m.pose[:3, 3]
    on_ray = camera + (points - camera) * (1.2 / 1.5)  # 30 cm in front of the wall, along each ray
    above, _ = emap.voxel_index(torch.as_tensor(on_ray, dtype=torch.float32))
    assert torch.allclose(p[above], torch.tensor(0.4))  # crossed once: prob_miss
    below, _ = emap.voxel_index(torch.as_tensor(points - np.array([0, 0, 0.3]), dtype=torch.float32))
    assert torch.all(~emap.observed[below]) and torch.allclose(p[below], torch.tensor(0.5))  # unknown behind


def test_log_odds_are_clamped_as_octomap_does():
    emap = ExplicitMap(ExplicitConfig(resolution=16, pixel_stride=1))
    m = flat_measurement()
    for _ in range(20):
        emap.integrate(m)
    assert emap.log_odds.max().item() == pytest.approx(logit(0.97))
    assert emap.log_odds.min().item() == pytest.approx(logit(0.12))


def test_background_rays_carve_free_space_only_when_asked():
    m = flat_measurement(depth_value=0.0, label=0)
    m = Measurement(m.rgb * 0 + 1, m.depth, m.labels, m.pose, m.intrinsics)
    carve, keep = ExplicitMap(ExplicitConfig(resolution=16)), ExplicitMap(ExplicitConfig(resolution=16, carve_background=False))
    carve.integrate(m)
    keep.integrate(m)
    assert carve.observed.sum() > 0 and keep.observed.sum() == 0


def test_scene_map_meshes_renders_and_scores_views():
    scene = load_scene("scene1")
    sim = Simulator(scene)
    emap = ExplicitMap(ExplicitConfig(resolution=64))
    for el, az in [(np.pi / 2, 0.0), (0.5, 0.8), (0.4, 3.0)]:
        emap.integrate(sim.render(view_to_pose(el, az)))
    mesh = emap.extract_target_mesh(scene.targets)
    assert mesh is not None and len(mesh.faces) > 100
    assert mesh.bounds[0][2] > -0.1  # cars stand on the ground
    image = emap.render_target_only(Intrinsics.from_fov(50, 50), view_to_pose(0.5, 0.8), scene.targets)
    assert image.shape == (50, 50, 3) and (image < 1).any() and (image == 1).all(axis=-1).any()
    views = np.array([[0.5, 0.8], [0.3, 4.0], [1.2, 2.0]])
    scores = emap.roi_scores(views, scene.targets)
    assert scores.shape == (3,) and np.all(scores >= 0)



def test_a_target_only_render_near_the_targets_and_in_chunks_equals_the_whole_ray_marched_at_once():
    """Marching only near the target voxels' box gives the first hits of marching the whole ray; rays are
    independent, so any chunk size gives the same pixels, bit for bit; the evaluation's renders (target voxels
    read once for all views) equal one render per view."""
    scene = load_scene("scene1")
    sim = Simulator(scene)
    emap = ExplicitMap(ExplicitConfig(resolution=64))
    for el, az in [(np.pi / 2, 0.0), (0.5, 0.8)]:
        emap.integrate(sim.render(view_to_pose(el, az)))
    k, poses = Intrinsics.from_fov(48, 48), [view_to_pose(0.5, 0.8), view_to_pose(0.9, 2.5)]
    solid, colours, box = emap._target_voxels(scene.targets)
    for pose in poses:
        whole = emap._first_hit_colours(k, pose, solid, colours, box, chunk_rays=k.width * k.height)
        assert (whole < 1).any() and (whole == 1).all(axis=-1).any()  # targets seen and background
        origins, dirs = (torch.as_tensor(a, dtype=torch.float32) for a in pixel_rays(k, pose))
        index, valid = emap._march(origins, dirs)  # every sample of every ray
        hit = solid[index] & valid
        first_hit = colours[index[torch.arange(len(index)), hit.float().argmax(dim=1)]]
        assert np.array_equal(whole.reshape(-1, 3), torch.where(hit.any(dim=1)[:, None], first_hit, 1.0).numpy())
        for chunk in (1000, 777, 4096):
            assert np.array_equal(emap._first_hit_colours(k, pose, solid, colours, box, chunk_rays=chunk), whole)
    renders = list(emap.target_only_renders(k, poses, scene.targets, z_min=0.0))
    for (render, cut), pose in zip(renders, poses):
        assert render is cut and np.array_equal(render, emap.render_target_only(k, pose, scene.targets))

def roi_test_map(wall: bool = False) -> ExplicitMap:
    """A map that knows every voxel free except: a target block T at +x, an unknown block beside it (between
    T and the +x side of the hemisphere), an equal unknown block far from T at -x, and optionally an
    occupied non-target wall between that block and the -x side."""
    emap = ExplicitMap(ExplicitConfig(resolution=32, candidate_scale=0.05))
    centres = emap.grid.first_centre() + emap.voxel * torch.arange(32.0)
    z, y, x = torch.meshgrid(centres, centres, centres, indexing="ij")
    x, y, z = x.reshape(-1), y.reshape(-1), z.reshape(-1)
    box = lambda x0, x1, half_width=0.3, top=0.6: (x > x0) & (x < x1) & (y.abs() < half_width) & (z > 0.0) & (z < top)  # noqa: E731
    emap.observed[:] = True
    emap.log_odds[:] = emap.l_min
    target, near, far = box(0.2, 0.5), box(0.5, 0.9), box(-0.9, -0.5)
    emap.log_odds[target] = emap.l_max
    emap.class_counts[target, 1] = 1.0
    emap.observed[near | far] = False
    emap.log_odds[near | far] = 0.0
    if wall:
        blocker = box(-1.3, -1.05, half_width=0.7, top=1.2)
        emap.log_odds[blocker] = emap.l_max
        emap.class_counts[blocker, 3] = 1.0
    return emap


def test_roi_utility_ranks_unknown_space_near_targets_first_and_stops_at_surfaces():
    """STE's ROI utility: unknown voxels near a target score more than equally many far from one, known
    free space scores nothing, and nothing behind the first occupied voxel of a ray counts."""
    plus_x, minus_x, top = [0.35, 0.0], [0.35, np.pi], [np.pi / 2, 0.0]  # low views from +x and -x, and the top
    near_side, far_side, above = roi_test_map().roi_scores(np.array([plus_x, minus_x, top]), (1,))
    assert near_side > 1.2 * far_side > 0   # the same unknown volume, closer to the target
    walled = roi_test_map(wall=True).roi_scores(np.array([plus_x, minus_x]), (1,))
    assert walled[0] == pytest.approx(near_side) and walled[1] < 0.1 * far_side   # the wall hides the far block
    known = roi_test_map()
    known.observed[:] = True
    assert np.all(known.roi_scores(np.array([plus_x, minus_x, top]), (1,)) == 0)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU")
def test_explicit_map_on_the_gpu_matches_the_cpu():
    sim = Simulator(load_scene("scene1"))
    maps = {d: ExplicitMap(ExplicitConfig(resolution=32), device=d) for d in ("cpu", "cuda")}
    for el, az in [(np.pi / 2, 0.0), (0.5, 0.8)]:
        m = sim.render(view_to_pose(el, az))
        for emap in maps.values():
            emap.integrate(m)
    k, pose, views = Intrinsics.from_fov(30, 30), view_to_pose(0.5, 0.8), np.array([[0.5, 0.8], [0.3, 4.0]])
    cpu, gpu = maps["cpu"], maps["cuda"]
    assert torch.equal(cpu.log_odds, gpu.log_odds.cpu())
    np.testing.assert_allclose(cpu.render_target_only(k, pose, (1,)), gpu.render_target_only(k, pose, (1,)), atol=1e-6)
    np.testing.assert_allclose(cpu.roi_scores(views, (1,)), gpu.roi_scores(views, (1,)), rtol=1e-5)
