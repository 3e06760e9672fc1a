from dataclasses import replace

import numpy as np
import pytest
import torch

from stair_lite.rendering import compositing_weights, ray_box_intersection, sample_along_rays


def test_constant_slab_has_geometric_transmittance():
    o, n = 0.3, 12
    w, t = compositing_weights(torch.full((1, n), o, dtype=torch.float64))
    expected_t = (1 - o) ** torch.arange(n, dtype=torch.float64)
    torch.testing.assert_close(t[0], expected_t)
    torch.testing.assert_close(w.sum(), torch.tensor(1 - (1 - o) ** n, dtype=torch.float64))


def test_weights_and_final_transmittance_sum_to_one():
    occ = torch.rand(50, 30, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    w, t = compositing_weights(occ)
    final = t[:, -1] * (1 - occ[:, -1])
    torch.testing.assert_close(w.sum(1) + final, torch.ones(50, dtype=torch.float64))
    assert torch.all(t[:, 1:] <= t[:, :-1])  # transmittance never increases


def test_step_occupancy_puts_all_weight_on_the_first_surface_sample():
    occ = torch.tensor([[0.0, 0.0, 1.0, 1.0, 0.0]])
    w, _ = compositing_weights(occ)
    torch.testing.assert_close(w, torch.tensor([[0.0, 0.0, 1.0, 0.0, 0.0]]))


def test_ray_box_intersection_of_axis_rays():
    origins = torch.tensor([[0.0, 0.0, 2.0], [3.0, 3.0, 3.0]])
    dirs = torch.tensor([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    t0, t1, hit = ray_box_intersection(origins, dirs, 1.5, near=0.2)
    assert hit.tolist() == [True, False]
    assert t0[0].item() == pytest.approx(0.5) and t1[0].item() == pytest.approx(3.5)


def test_samples_are_sorted_inside_the_interval_and_seeded():
    t0, t1 = torch.tensor([0.5, 1.0]), torch.tensor([3.5, 2.0])
    depth = torch.tensor([2.0, 0.0])
    a = sample_along_rays(t0, t1, 16, torch.Generator().manual_seed(0), depth, n_surface=8, band=0.1)
    b = sample_along_rays(t0, t1, 16, torch.Generator().manual_seed(0), depth, n_surface=8, band=0.1)
    torch.testing.assert_close(a, b)
    assert a.shape == (2, 24)
    assert torch.all(a[:, 1:] >= a[:, :-1])
    assert torch.all(a >= t0[:, None]) and torch.all(a <= t1[:, None])
    near_surface = ((a[0] - 2.0).abs() <= 0.1).sum()
    assert near_surface >= 8  # the depth-guided samples sit around the measured depth
    fixed = sample_along_rays(t0, t1, 4)
    torch.testing.assert_close(fixed[1], torch.tensor([1.125, 1.375, 1.625, 1.875]))  # stratum centres


def test_training_rays_end_just_behind_their_measured_surface():
    """A measured depth says nothing of what lies behind the surface: a training ray that hit something is
    sampled up to depth + behind_surface, a ray that hit nothing (depth 0) to the cube's far side."""
    from stair_lite.config import FieldConfig, RenderConfig
    from stair_lite.field import SemanticField
    from stair_lite.rendering import sample_field

    field = SemanticField(FieldConfig(grid_resolution=8), seed=0)
    cfg = RenderConfig(n_samples=64, n_surface_samples=16, behind_surface=0.03)
    origins = torch.tensor([[0.0, 0.0, 2.0], [0.0, 0.0, 2.0]])
    dirs = torch.tensor([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    depth = torch.tensor([2.0, 0.0])  # the first ray hit the z = 0 plane
    t = sample_field(field, origins, dirs, cfg, generator=torch.Generator().manual_seed(0), depth=depth)["t"]
    assert t[0].max() <= 2.03 + 1e-6 and t[0].max() > 2.0  # ends just behind the surface, and reaches it
    assert t[1].max() > 3.4  # a ray that hit nothing: to the cube's far side (t = 3.5)
    t_off = sample_field(field, origins, dirs, replace(cfg, behind_surface=None), generator=torch.Generator().manual_seed(0),
                         depth=depth)["t"]
    assert t_off[0].max() > 3.4  # switched off: the whole ray
    t_render = sample_field(field, origins, dirs, cfg)["t"]  # rendering (no measured depth) samples the whole ray
    assert t_render[0].max() > 3.4


def test_compositing_the_active_samples_is_the_dense_sum_over_them():
    """composite() sums w_i v_i over the listed samples only: the dense sum with every other term zero."""
    from stair_lite.rendering import composite

    g = torch.Generator().manual_seed(0)
    weights, values = torch.rand(30, 12, generator=g), torch.rand(30, 12, 4, generator=g)
    active = torch.rand(30, 12, generator=g) > 0.6
    rows = active.view(-1).nonzero().squeeze(1)
    dense = (weights[..., None] * values * active[..., None]).sum(dim=1)
    torch.testing.assert_close(composite(values.view(-1, 4)[rows], rows, weights), dense)
    assert composite(values.view(-1, 4)[:0], rows[:0], weights).abs().sum() == 0  # no active sample: zero


def test_a_ray_reaches_the_cells_in_front_of_its_depth_and_a_miss_crosses_the_cube():
    """``reached_vertices`` against the cells counted by hand: a ray along +x through the middle of a cell row reaches
    the vertices of the cells from the cube's face to the one holding its surface point, and no further; a ray
    that hit nothing (depth 0) reaches the whole row."""
    from stair_lite.lattice import Lattice, flat_index
    from stair_lite.rendering import reached_vertices

    lattice = Lattice(11, 1.0)  # vertices every 0.2 m, at x = -1, -0.8, ..., 1
    origins = torch.tensor([[-3.0, 0.1, -0.1], [-3.0, 0.1, -0.1]])
    dirs = torch.tensor([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    depth = torch.tensor([2.59, 0.0])  # the first hits a surface at x = -0.41, inside the cell [-0.6, -0.4]
    def row(last_cell):
        i = torch.arange(last_cell + 2)
        j, k = torch.tensor([5, 6]), torch.tensor([4, 5])  # y = 0.1 lies between vertices 5 and 6, z = -0.1 between 4 and 5
        ii, jj, kk = torch.meshgrid(i, j, k, indexing="ij")
        return set(flat_index(ii.reshape(-1), jj.reshape(-1), kk.reshape(-1), 11).tolist())
    def reached(rows):
        return set(torch.nonzero(reached_vertices(lattice, origins[rows], dirs[rows], depth[rows], near=0.2)).squeeze(1).tolist())
    assert reached([0]) == row(2)
    assert reached([1]) == row(9)



def test_reached_vertices_marks_the_cells_of_its_points_along_each_ray():
    """Against the rule computed the plain way, on random rays (hits and misses) of a paper-size lattice: the cell of
    every point along a ray, every half vertex spacing up to its depth, by integer indices (``flat_index``); the
    function computes the index as one float product, in place, and makes the points a part of the chunk's rays at a
    time (with the chunk's number of points per ray), to hold less memory at once."""
    from stair_lite.lattice import Lattice, flat_index
    from stair_lite.rendering import reached_vertices

    lattice, near = Lattice(128), 0.2
    rng = torch.Generator().manual_seed(0)
    origins = torch.nn.functional.normalize(torch.randn(3000, 3, generator=rng), dim=1) * 2.0
    origins[:, 2] = origins[:, 2].abs()
    dirs = torch.nn.functional.normalize(-origins + 0.8 * torch.randn(3000, 3, generator=rng), dim=1)
    depth = torch.where(torch.rand(3000, generator=rng) < 0.7, 1.0 + 2.0 * torch.rand(3000, generator=rng), torch.zeros(3000))
    r = lattice.resolution
    t_near, t_far, hit = ray_box_intersection(origins, dirs, lattice.bound, near)
    t_end = torch.where(depth > 0, torch.minimum(t_far, depth), t_far)
    rows = torch.nonzero(hit & (t_end >= t_near)).squeeze(1)
    length = t_end[rows] - t_near[rows]
    n = int(torch.ceil(length.max() / (0.5 * lattice.spacing))) + 1   # all rows in one chunk, as the function takes them
    points = origins[rows, None, :] + (t_near[rows, None] + length[:, None] * torch.linspace(0.0, 1.0, n))[..., None] * dirs[rows, None, :]
    cell = lattice.vertex_units(points.reshape(-1, 3)).floor().clamp(0, r - 2).long()
    cells = torch.zeros((r - 1) ** 3, dtype=torch.bool)
    cells[flat_index(cell[:, 0], cell[:, 1], cell[:, 2], r - 1)] = True
    vertices = torch.zeros(r, r, r, dtype=torch.bool)   # [z, y, x]: a vertex is reached when one of its 8 cells is
    marked = cells.view(r - 1, r - 1, r - 1)
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                vertices[dz:dz + r - 1, dy:dy + r - 1, dx:dx + r - 1] |= marked
    assert len(rows) > 1000
    assert torch.equal(reached_vertices(lattice, origins, dirs, depth, near), vertices.reshape(-1))
    assert torch.equal(reached_vertices(lattice, origins, dirs, depth, near, rays_per_part=257), vertices.reshape(-1))

def kept_samples(skip, origins, dirs, cfg):
    """Which of every ray's unjittered render samples (R, S) lie in a cell ``skip`` keeps, and their parameters t,
    found by sampling every ray in full (what the culls and windows below must agree with)."""
    t_near, t_far, hit = ray_box_intersection(origins, dirs, skip.lattice.bound, cfg.near)
    t_far = torch.where(hit & (t_far > t_near), t_far, t_near + 1e-3)
    t = sample_along_rays(t_near, t_far, cfg.n_samples)
    return hit[:, None] & skip.lookup(origins[:, None, :] + t[..., None] * dirs[:, None, :]), t, t_near, t_far, hit


def test_a_kept_cells_image_footprint_holds_every_ray_that_meets_one_and_culls_the_rest():
    """The pixels with a window (``SkipGrid.ray_windows`` with one depth bin: the kept cells' image footprint) are
    conservative: every pixel whose ray has a sample in a kept cell lies among them, for
    blocks, scattered cells and cells on the cube's faces, from high, low and top views; it leaves most of the image
    out for a small block; and it gives up (None) when a kept cell reaches behind the camera."""
    from stair_lite.config import RenderConfig
    from stair_lite.geometry import Intrinsics, pixel_rays, view_to_pose
    from stair_lite.lattice import Lattice
    from stair_lite.rendering import SkipGrid

    lattice, cfg = Lattice(24), RenderConfig(n_samples=96)
    k = Intrinsics.from_fov().scaled(0.2)
    block = torch.zeros(24, 24, 24, dtype=torch.bool)  # [z, y, x]
    block[3:6, 10:13, 8:11] = True
    scattered = torch.as_tensor(np.random.default_rng(1).random((24, 24, 24)) < 0.003)
    scattered[:4], scattered[20:], scattered[:, :4], scattered[:, 20:], scattered[:, :, :4], scattered[:, :, 20:] = (False,) * 6
    # (inside |x|, |y|, |z| < 1.1 m: in front of every camera on the hemisphere of radius 2 m)
    for mask in (block, scattered):
        skip = SkipGrid(mask, lattice)
        for view in ((0.3, 0.4), (1.2, 2.0), (np.pi / 2, 0.0), (0.05, 5.0)):
            pose = view_to_pose(*view)
            o, d = (torch.as_tensor(a, dtype=torch.float32) for a in pixel_rays(k, pose))
            footprint = torch.isfinite(skip.ray_windows(k, pose, depth_bins=1)[0])
            live = kept_samples(skip, o, d, cfg)[0].any(dim=1)
            assert live.any() and torch.all(footprint[live]), view  # a superset of the rays that meet a kept cell
            if mask is block:
                assert footprint.float().mean() < 0.2, view  # and it culls
    edge = torch.zeros(24, 24, 24, dtype=torch.bool)
    edge[20:, 12, 23] = True  # cells at the cube's face x = 1.5, high up
    assert SkipGrid(edge, lattice).ray_windows(k, view_to_pose(np.pi / 4, 0.0)) is None  # behind the camera
    assert not torch.isfinite(SkipGrid(torch.zeros_like(edge), lattice).ray_windows(k, view_to_pose(0.5, 0.0))[0]).any()


def test_lattice_block_holds_the_vertices_in_a_box():


    from stair_lite.lattice import Lattice

    lattice = Lattice(11, bound=1.0)  # vertices at -1, -0.8, ..., 1
    block = lattice.block(torch.tensor([-0.85, -0.01, 0.95]), torch.tensor([-0.19, 0.01, 2.0]))
    assert block == (slice(1, 5), slice(5, 6), slice(10, 11))
    points = lattice.block_points(block)
    full = lattice.points()
    inside = ((full >= torch.tensor([-0.85, -1e-6, 0.95])) & (full <= torch.tensor([-0.19, 1e-6, 2.0]))).all(dim=1)
    assert torch.equal(points, full[inside])
    assert lattice.block(torch.tensor([0.1, 0.1, 0.1]), torch.tensor([0.15, 0.9, 0.9]))[0] == slice(6, 6)  # none


def test_ray_windows_hold_every_kept_sample_and_shorten_the_rays():
    """``SkipGrid.ray_windows`` bounds, per pixel, the depths at which its ray can meet a kept cell: every sample that
    sampling the whole ray finds in a kept cell lies in the interval and in the sample window ``window_indices``
    makes of it, and ``strata_centres`` gives those samples the same floats as ``sample_along_rays``; the windows
    are much shorter than the rays for two blocks apart, and shorter with more depth bins. Intervals that end a
    bin early (as if a cell were thinner) miss kept samples: the check can fail."""
    from stair_lite.config import RenderConfig
    from stair_lite.geometry import Intrinsics, pixel_rays, view_to_pose
    from stair_lite.lattice import Lattice
    from stair_lite.rendering import SkipGrid, strata_centres, window_indices

    lattice, cfg = Lattice(24), RenderConfig(n_samples=64)
    keep = torch.zeros(24, 24, 24, dtype=torch.bool)  # [z, y, x]
    keep[4:9, 6:10, 10:14] = True
    keep[3:6, 15:19, 4:7] = True
    skip = SkipGrid(keep, lattice)
    k = Intrinsics.from_fov().scaled(0.1)
    missed_by_thinner = 0
    for view in ((0.4, 1.0), (1.3, 4.0), (np.pi / 2, 0.0)):
        pose = view_to_pose(*view)
        o, d = (torch.as_tensor(a, dtype=torch.float32) for a in pixel_rays(k, pose))
        kept, every, t_near, t_far, hit = kept_samples(skip, o, d, cfg)
        index = torch.arange(cfg.n_samples).expand_as(every)
        assert torch.equal(strata_centres(t_near[:, None], t_far[:, None], index, cfg.n_samples), every)
        widths = {}
        for bins in (1, 16):
            t_lo, t_hi = skip.ray_windows(k, pose, depth_bins=bins)
            assert torch.all((every >= t_lo[:, None]) & (every <= t_hi[:, None]) | ~kept), (view, bins)
            first, last = window_indices(t_near, t_far, cfg.n_samples, t_lo, t_hi, hit & (t_hi >= t_lo))
            assert not (kept & ((index < first[:, None]) | (index >= last[:, None]))).any(), (view, bins)
            widths[bins] = (last - first)[kept.any(dim=1)].float().mean()
        assert widths[16] < widths[1] < 0.6 * cfg.n_samples, view
        step = (t_hi - t_lo)[torch.isfinite(t_lo)].min()  # the shortest interval (a bin at least): end every one earlier
        missed_by_thinner += int((kept & (every > (t_hi - step)[:, None])).sum())
    assert missed_by_thinner > 0


