import numpy as np
import pytest
import torch

import stair_lite  # noqa: F401
from stair_lite.classes import BACKGROUND, NUM_CLASSES
from stair_lite.config import FieldConfig, PlanConfig, get_preset
from stair_lite.field import SemanticField
from stair_lite.geometry import Intrinsics, fibonacci_hemisphere, view_to_pose, view_to_position
from stair_lite.lattice import Lattice
from stair_lite.planners import MIN_SEPARATION, make_planner, far_enough
from stair_lite.utility import (CLASS_TIE, FieldSnapshot, UtilityOptions, class_entropy, point_entropy, ray_classes,
                                render_uncertainty, score_views,
                                target_mask, target_probability)


def test_point_entropy_closed_form_and_limits():
    o = torch.tensor([0.0, 0.5, 1.0, 0.1], dtype=torch.float64)
    h = point_entropy(o)
    assert h[1].item() == pytest.approx(np.log(2))
    assert h[0].item() == pytest.approx(0, abs=1e-5) and h[2].item() == pytest.approx(0, abs=1e-5)
    assert h[3].item() == pytest.approx(-(0.1 * np.log(0.1) + 0.9 * np.log(0.9)))
    assert torch.all(torch.isfinite(h))


class SlabField:
    """A stand-in field: a horizontal slab of occupancy o_slab between z0 and z1, labelled ``cls``; measured rays
    have reached every vertex (nothing is unknown)."""

    def __init__(self, o_slab, z0=0.2, z1=0.6, cls=1, o_free=0.0):
        self.cfg = FieldConfig(grid_resolution=64)
        self.lattice = Lattice(64)
        self.device = torch.device("cpu")
        self.reached = torch.ones(64**3, dtype=torch.bool)
        self.o_slab, self.z0, self.z1, self.cls, self.o_free = o_slab, z0, z1, cls, o_free

    def query(self, x):
        inside = (x[:, 2] > self.z0) & (x[:, 2] < self.z1) & (x[:, :2].abs() < 0.5).all(dim=1)
        occ = torch.where(inside, torch.tensor(self.o_slab), torch.tensor(self.o_free))
        sem = torch.zeros(len(x), 7)
        sem[inside, self.cls] = 1.0
        sem[~inside, 0] = 1.0
        return {"occ": occ, "sem": sem}


def test_ray_entropy_is_transmittance_weighted():
    """Samples behind an opaque surface add nothing: a ray's entropy is the entropy in front of it."""
    k = Intrinsics.from_fov(4, 4, 20)
    top = [np.array([[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 2.0], [0, 0, 0, 1]])]
    uncertain = render_uncertainty(SlabField(0.5), k, top, 400)["h_ray"]
    opaque = render_uncertainty(SlabField(1.0), k, top, 400)["h_ray"]
    # a slab of o = 0.5: sum_i T_i H = ln2 * sum_i 0.5^i -> 2 ln 2 (geometric series) for many samples
    torch.testing.assert_close(uncertain, torch.full_like(uncertain, 2 * np.log(2)), rtol=1e-3, atol=1e-3)
    assert opaque.abs().max() < 1e-4


def test_exploitation_counts_only_target_rays():
    field = SlabField(0.5, cls=2)
    k = Intrinsics.from_fov(16, 16, 60)
    views = fibonacci_hemisphere(6)
    as_target = score_views(field, views, (2,), k, 128, UtilityOptions(epsilon=0.2))
    not_target = score_views(field, views, (1,), k, 128, UtilityOptions(epsilon=0.2))
    np.testing.assert_allclose(as_target.exploration, not_target.exploration)
    assert np.all(not_target.exploitation == 0)
    assert np.all(as_target.exploitation > 0) and np.all(as_target.exploitation <= as_target.exploration + 1e-6)
    np.testing.assert_allclose(as_target.utility, as_target.exploitation + 0.2 * as_target.exploration, rtol=1e-6)


def test_negative_epsilon_is_rejected():
    with pytest.raises(ValueError, match="epsilon must be a number from 0 to"):
        UtilityOptions(epsilon=-0.1)


def test_target_mask_dilation():
    sem = torch.zeros(1, 5, 5, 7)
    sem[..., 0] = 1
    sem[0, 2, 2] = torch.nn.functional.one_hot(torch.tensor(3), 7).float()
    assert target_mask(sem, (3,)).sum() == 1
    assert target_mask(sem, (3,), dilation=1).sum() == 9


def test_snapshot_scores_agree_with_the_exact_field():
    field = SemanticField(FieldConfig(grid_resolution=16, rgb_hidden=(16,)), seed=0)
    with torch.no_grad():
        generator = torch.Generator().manual_seed(0)
        for grid in (field.grid_occ, field.grid_app):
            grid.normal_(0, 2.0, generator=generator)
        field.reached.fill_(True)  # as if measurements had reached every cell (FieldConfig.reached_only)
    k = Intrinsics.from_fov(12, 12)
    views = fibonacci_hemisphere(12)
    exact = score_views(field, views, (1, 2), k, 48)
    fast = score_views(FieldSnapshot(field, resolution=64), views, (1, 2), k, 48)
    assert np.corrcoef(exact.exploration, fast.exploration)[0, 1] > 0.9


@pytest.mark.parametrize("name", ["fixed", "max_distance", "uniform"])
def test_baseline_planners_are_seeded_and_never_revisit(name):
    visited = np.array([[np.pi / 2, 0.0]])
    a, b = make_planner(name, get_preset("paper"), seed=5), make_planner(name, get_preset("paper"), seed=5)
    for _ in range(9):
        va, vb = a.next_view(None, visited, (1,)).view, b.next_view(None, visited, (1,)).view
        np.testing.assert_array_equal(va, vb)
        assert far_enough(va[None], visited)[0]
        visited = np.vstack([visited, va])


def test_fixed_pattern_spirals_down_the_hemisphere():
    planner = make_planner("fixed", get_preset("paper"), seed=0)
    visited = np.array([[np.pi / 2, 0.0]])
    elevations = []
    for _ in range(9):
        v = planner.next_view(None, visited, (1,)).view
        visited = np.vstack([visited, v])
        elevations.append(v[0])
    assert np.all(np.diff(elevations) < 0)


def test_max_distance_picks_the_farthest_candidate():
    planner = make_planner("max_distance", get_preset("paper"), seed=0)
    d = planner.next_view(None, np.array([[np.pi / 2, 0.0]]), (1,))
    assert d.view[0] < np.radians(10)  # far from the top view: near the horizon


class TwoBoxField:
    """A stand-in field: two equal boxes of occupancy 0.5 (maximal entropy), of class 1 at +x and class 3
    at -x, in an empty scene; measured rays have reached every vertex."""

    def __init__(self):
        self.cfg = FieldConfig(grid_resolution=48)
        self.lattice = Lattice(48)
        self.device = torch.device("cpu")
        self.reached = torch.ones(48**3, dtype=torch.bool)

    def query(self, x):
        in_box = [((x - torch.tensor(c)).abs() < 0.25).all(dim=1) for c in ((0.6, 0.0, 0.3), (-0.6, 0.0, 0.3))]
        sem = torch.zeros(len(x), 7)
        sem[:, 0] = 1.0
        for box, cls in zip(in_box, (1, 3)):
            sem[box] = torch.nn.functional.one_hot(torch.tensor(cls), 7).float()
        return {"occ": (in_box[0] | in_box[1]).float() * 0.5, "sem": sem}


@pytest.mark.parametrize("target,side", [(1, 1.0), (3, -1.0)])
def test_stair_planner_looks_at_the_uncertain_target(target, side):
    """Both boxes are equally uncertain; with epsilon 0 only the target's rays count (Eqs. 13-15), so the
    chosen camera stands on the target's side, where the target looks largest and hides the other box.
    The same candidates are scored for both targets, so a utility that ignored the mask would choose
    the same view twice and fail one of the two cases."""
    field = TwoBoxField()
    cfg = PlanConfig(n_uniform=40, top_k=3, n_resample=3, candidate_scale=0.05, candidate_samples=64, epsilon=0.0)
    d = make_planner("stair", get_preset("lite", plan=cfg), seed=0).next_view(field, np.array([[np.pi / 2, 0.0]]), (target,))
    camera = view_to_position(*d.view)
    assert side * camera[0] > 0.5, camera
    assert d.scores.exploitation[d.chosen_index] == d.scores.exploitation.max()


def test_stair_planner_prefers_the_uncertain_target_and_skips_visited_views():
    field = SlabField(0.5, cls=1)
    cfg = PlanConfig(n_uniform=30, top_k=3, n_resample=3, candidate_scale=0.04, candidate_samples=64)
    planner = make_planner("stair", get_preset("lite", plan=cfg), seed=0)
    visited = np.array([[np.pi / 2, 0.0]])
    d = planner.next_view(field, visited, (1,))
    assert len(d.candidates) == 30 + 9
    assert d.chosen_index == int(np.argmax(np.where(far_enough(d.candidates, visited), d.scores.utility, -np.inf)))
    assert far_enough(d.view[None], visited)[0]
    assert np.degrees(MIN_SEPARATION) == pytest.approx(8.1, abs=0.05)


def test_the_spread_variant_scores_as_stair_and_keeps_its_views_35_degrees_apart():
    """``stair_spread`` ranks with STAIR's utility (the same scores for the same candidates) and picks the best
    candidate at least 35 degrees from every visited view; with every view within that of a visited one it says so."""
    field = SlabField(0.5, cls=1)
    cfg = PlanConfig(n_uniform=30, top_k=3, n_resample=3, candidate_scale=0.04, candidate_samples=64)
    preset = get_preset("lite", plan=cfg)
    visited = np.array([[np.pi / 2, 0.0], [np.radians(30), 0.0], [np.radians(30), np.pi]])
    spread, stair = make_planner("stair_spread", preset, seed=0), make_planner("stair", preset, seed=0)
    assert np.degrees(spread.min_separation) == pytest.approx(35.0) and stair.min_separation == MIN_SEPARATION
    views = fibonacci_hemisphere(12)
    np.testing.assert_array_equal(spread.utility(field, views, visited, (1,)), stair.utility(field, views, visited, (1,)))
    d = spread.next_view(field, visited, (1,))
    allowed = far_enough(d.candidates, visited, np.radians(35.0))
    assert 0 < allowed.sum() < len(d.candidates)  # the rule leaves some candidates out and some in
    assert d.chosen_index == int(np.argmax(np.where(allowed, d.scores.utility, -np.inf)))
    one_stage = make_planner("stair_spread", get_preset("lite", plan=PlanConfig(
        n_uniform=30, top_k=3, n_resample=0, candidate_scale=0.04, candidate_samples=64)), seed=0)
    assert len(one_stage.next_view(field, visited, (1,)).candidates) == 30  # no second stage: the first stage alone
    crowded = fibonacci_hemisphere(60)  # every view of the hemisphere lies within 35 degrees of one of these
    with pytest.raises(RuntimeError, match="within 35.0 degrees .* of one of the 60 visited views"):
        spread.next_view(field, crowded, (1,))


@pytest.mark.parametrize("target,side", [(1, 1.0), (3, -1.0)])
def test_the_ring_variant_looks_at_the_target_from_the_spiral_elevation_of_its_step(target, side):
    """``stair_rings`` puts its n-th view after the top one on the fixed spiral's n-th ring and chooses the azimuth by
    STAIR's utility: of N_uni + K N_re candidates on that ring (STAIR's count), the best, on the target's side."""
    field = TwoBoxField()
    cfg = PlanConfig(n_uniform=40, top_k=3, n_resample=3, candidate_scale=0.05, candidate_samples=64, epsilon=0.0)
    preset = get_preset("lite", plan=cfg)
    rings, stair = make_planner("stair_rings", preset, seed=0), make_planner("stair", preset, seed=0)
    spiral = make_planner("fixed", preset, seed=0).sequence
    views = fibonacci_hemisphere(12)
    np.testing.assert_array_equal(rings.utility(field, views, views[:1], (target,)),
                                  stair.utility(field, views, views[:1], (target,)))
    visited = np.array([[np.pi / 2, 0.0]])
    for step in range(3):
        d = rings.next_view(field, visited, (target,))
        assert len(d.candidates) == 40 + 3 * 3
        np.testing.assert_allclose(d.candidates[:, 0], spiral[step, 0])  # the spiral's ring for this step
        assert d.chosen_index == int(np.argmax(np.where(far_enough(d.candidates, visited), d.scores.utility, -np.inf)))
        assert side * view_to_position(*d.view)[0] > 0.3, (step, d.view)
        visited = np.vstack([visited, d.view])


def test_unknown_planner_is_named():
    with pytest.raises(ValueError, match="unknown planner 'greedy'"):
        make_planner("greedy", get_preset("paper"), seed=0)


def test_nearest_vertex_along_rays_is_the_nearest_vertex_of_each_sample():
    """The snapshot's fused lookup (vertex units from the ray's start) names the vertex nearest_index names,
    but for samples lying within float rounding of halfway between two vertices."""
    from stair_lite.lattice import Lattice

    lattice = Lattice(64)
    rng = np.random.default_rng(0)
    origins = torch.as_tensor(rng.uniform(-3, 3, (500, 3)), dtype=torch.float32)
    dirs = torch.nn.functional.normalize(torch.as_tensor(rng.normal(size=(500, 3)), dtype=torch.float32), dim=1)
    t = torch.as_tensor(np.sort(rng.uniform(0, 6, (500, 64)), axis=1), dtype=torch.float32)
    fused = lattice.nearest_index_on_rays(origins, dirs, t)
    direct = lattice.nearest_index(origins[:, None, :] + t[..., None] * dirs[:, None, :])
    assert fused.shape == direct.shape == (500, 64)
    assert (fused == direct).float().mean() > 0.999


class MixedSlabField(SlabField):
    """A half-occupied slab with split labels: probability p of the target class 2 and 1 - p of its look-alike 4."""

    def __init__(self, p, **kwargs):
        super().__init__(0.5, cls=2, **kwargs)
        self.p = p

    def query(self, x):
        out = super().query(x)
        inside = out["sem"][:, 2] > 0
        out["sem"][inside, 2], out["sem"][inside, 4] = self.p, 1.0 - self.p
        return out


def test_class_entropy_and_target_probability_in_closed_form():
    sem = torch.tensor([[1 / 7] * 7, [1.0] + [0.0] * 6, [0.0, 0.0, 0.3, 0.0, 0.7, 0.0, 0.0]])
    torch.testing.assert_close(class_entropy(sem), torch.tensor([np.log(7), 0.0, -(0.3 * np.log(0.3) + 0.7 * np.log(0.7))], dtype=torch.float32))
    torch.testing.assert_close(target_probability(sem, (2, 4)), torch.tensor([2 / 7, 0.0, 1.0]))


def test_the_soft_mask_weighs_each_ray_by_its_target_probability():
    k, views, n = Intrinsics.from_fov(16, 16, 60), fibonacci_hemisphere(5), 128
    for field in (SlabField(0.5, cls=2), MixedSlabField(0.4)):
        soft = score_views(field, views, (2,), k, n, UtilityOptions(soft_mask=True))
        out = render_uncertainty(field, k, [view_to_pose(*v) for v in views], n)
        expected = (out["h_ray"] * target_probability(out["sem"], (2,))).sum(dim=(1, 2)).numpy()
        np.testing.assert_allclose(soft.exploitation, expected, rtol=1e-5)
        assert np.all(soft.exploitation > 0) and np.all(soft.exploitation <= soft.exploration + 1e-4)
    # 40 % target, 60 % sofa on every ray: the argmax test never says target, the soft mask counts 40 %
    assert np.all(score_views(MixedSlabField(0.4), views, (2,), k, n, UtilityOptions()).exploitation == 0)


def test_the_semantic_term_adds_lambda_times_the_summed_class_entropy():
    k, views, n = Intrinsics.from_fov(16, 16, 60), fibonacci_hemisphere(5), 128
    paper = score_views(MixedSlabField(0.5), views, (2,), k, n, UtilityOptions())
    semantic = score_views(MixedSlabField(0.5), views, (2,), k, n, UtilityOptions(semantic_weight=0.3))
    out = render_uncertainty(MixedSlabField(0.5), k, [view_to_pose(*v) for v in views], n)
    np.testing.assert_allclose(semantic.semantic, class_entropy(out["sem"]).sum(dim=(1, 2)).numpy(), rtol=1e-5)
    np.testing.assert_allclose(semantic.utility, paper.utility + 0.3 * semantic.semantic, rtol=1e-5)
    assert np.all(semantic.semantic > 0)  # rays through the split slab: up to ln 2 each
    certain = score_views(SlabField(1.0, cls=2), views, (2,), k, n, UtilityOptions(semantic_weight=0.3))
    assert np.abs(certain.semantic).max() < 1e-3  # opaque, one-hot labels: nothing to learn about classes
    with pytest.raises(ValueError, match="semantic_weight must be a finite number >= 0, got -1"):
        UtilityOptions(semantic_weight=-1)


def test_the_planner_variants_beyond_the_paper_carry_their_options():
    preset = get_preset("smoke")
    assert make_planner("stair_soft", preset, seed=0).options.soft_mask
    assert make_planner("stair_semantic", preset, seed=0).options.semantic_weight > 0
    paper = make_planner("stair", preset, seed=0).options
    assert not paper.soft_mask and paper.semantic_weight == 0


class CountedSlabField(SlabField):
    """The slab field with the measurement counts the coverage and Fisher utilities read: ``views`` views and ``rays``
    rays saw a surface at every vertex."""

    def __init__(self, o_slab, views=0.0, rays=0.0):
        super().__init__(o_slab)
        n = self.lattice.resolution**3
        self.surface_views, self.surface_rays = torch.full((n,), float(views)), torch.full((n,), float(rays))


def _novelty_scores(name, field, views=np.array([[np.pi / 2, 0.0], [1.2, 0.5]])):
    planner = make_planner(name, get_preset("lite"), seed=0)
    return planner.utility(field, views, np.zeros((0, 2)), (1,))


@pytest.mark.parametrize("name, count", [("coverage", "views"), ("fisher", "rays")])
def test_a_surface_seen_more_often_scores_less_by_its_count(name, count):
    """Coverage weighs a surface by 1 / (1 + views that saw it), Fisher by 1 / (1 + rays that saw it): with every
    vertex seen once, each view's score halves."""
    fresh = _novelty_scores(name, CountedSlabField(1.0))
    seen_once = _novelty_scores(name, CountedSlabField(1.0, **{count: 1.0}))
    assert np.all(fresh > 0)
    np.testing.assert_allclose(seen_once, fresh / 2, rtol=1e-5)


def test_fisher_squares_the_rendering_weights_where_coverage_sums_them():
    """Through a half-transparent target slab (o = 0.5 at every sample), a ray's weights are 1/2, 1/4, 1/8, ...: they
    sum to 1 (coverage) and their squares to 1/3 (Fisher, the squared sensitivity), in closed form."""
    field = CountedSlabField(0.5)
    top = np.array([[np.pi / 2, 0.0]])
    ratio = _novelty_scores("fisher", field, top) / _novelty_scores("coverage", field, top)
    assert ratio[0] == pytest.approx(1 / 3, rel=0.02)


class HalfSeenField(SlabField):
    """An opaque target block at the origin whose far side (x > 0.35 m) no measured ray reached."""

    def __init__(self):
        super().__init__(1.0, z0=0.0, z1=0.8)
        self.reached = self.lattice.points()[:, 0] < 0.35
        self.surface_views = self.surface_rays = torch.zeros(self.lattice.resolution**3)


def test_a_view_onto_unseen_space_scores_above_a_view_onto_seen_space():
    """With the unknown marked (lite's planning renders), the view from the unseen side (camera at +x) scores above the
    view from the seen side (-x), which meets the opaque block before any unknown space; with the unknown unmarked
    (``stair_unmarked``: the rule before the league, as the authors' code in effect), both see the same block and score
    the same."""
    views = np.array([[0.3, 0.0], [0.3, np.pi]])  # the camera at +x, then at -x
    marked, unmarked = (make_planner(name, get_preset("lite"), seed=0).utility(HalfSeenField(), views, np.zeros((0, 2)), (1,))
                        for name in ("stair", "stair_unmarked"))
    assert marked[0] > 1.5 * marked[1]
    assert unmarked[0] == pytest.approx(unmarked[1], rel=0.05)


class ShellUnreachedField(SlabField):
    """An opaque target slab at the centre; measured rays reached every vertex but those farther than ``inner`` from
    the scene's centre on the +x side (the outer shell near the cameras a mission has used there)."""

    def __init__(self, inner: float):
        super().__init__(1.0, z0=0.0, z1=0.4)
        points = self.lattice.points()
        self.reached = ~((points.norm(dim=1) > inner) & (points[:, 0] > 0))
        self.surface_views = self.surface_rays = torch.zeros(self.lattice.resolution**3)


def test_the_unknown_is_marked_only_within_the_volume_to_reconstruct():
    """``unknown_within`` R: the planning snapshot gives the prior occupancy to unreached vertices within R of the
    scene's centre only; beyond, they keep the field's own (empty) occupancy. Without it, the whole cube is marked."""
    field = ShellUnreachedField(inner=1.2)
    points = field.lattice.points()
    radius, unreached = points.norm(dim=1), ~field.reached
    ball = FieldSnapshot(field, unknown_occupancy=0.5, unknown_within=1.5).table[:, 0]
    cube = FieldSnapshot(field, unknown_occupancy=0.5).table[:, 0]
    shell, beyond = unreached & (radius <= 1.5), unreached & (radius > 1.5)
    assert shell.any() and beyond.any()
    assert torch.all(ball[shell] == 0.5) and torch.all(cube[shell] == 0.5)
    assert torch.all(ball[beyond] == 0.0) and torch.all(cube[beyond] == 0.5)
    with pytest.raises(ValueError, match="unknown_within must be a finite distance > 0"):
        UtilityOptions(unknown_within=-1.0)


def test_unknown_among_the_cameras_pulls_views_only_when_the_whole_cube_is_marked():
    """The unreached cube beyond the inscribed ball on the +x side (where the cameras a mission used stand): marking
    the whole cube (``stair``) makes a camera there (azimuth 0) score far above its mirror image at azimuth 180, as its
    target rays start in unknown space; ``stair_volume`` (only the ball inscribed in the cube) scores the two alike."""
    views = np.array([[np.radians(40), 0.0], [np.radians(40), np.pi]])
    cube, ball = (make_planner(name, get_preset("lite"), seed=0).utility(ShellUnreachedField(inner=1.5), views,
                                                                         np.zeros((0, 2)), (1,))
                  for name in ("stair", "stair_volume"))
    assert cube[0] > 1.5 * cube[1]
    assert ball[0] == pytest.approx(ball[1], rel=0.05)


def test_unknown_vertices_near_a_target_surface_take_its_class_as_the_dense_rule_gives():
    """Planning's snapshot gives each unknown vertex within the radius of a target surface vertex (occupied, a target
    by argmax, known) the one-hot class of the nearest such vertex, and leaves every other row as it was: against the
    rule over every vertex at once (a one-hot table of all vertices, chosen row by row), on a random field."""
    import torch.nn.functional as F
    from scipy.ndimage import distance_transform_edt

    from stair_lite.lattice import Lattice
    from stair_lite.utility import _unknown_near_targets_as_targets

    lattice, targets, radius = Lattice(24), (3, 5), 0.3
    gen = torch.Generator().manual_seed(0)
    occ = torch.rand(24**3, generator=gen)
    sem = torch.softmax(3 * torch.randn(24**3, 7, generator=gen), dim=1)
    unknown = torch.rand(24**3, generator=gen) < 0.4
    surface = (occ > 0.5) & torch.isin(sem.argmax(dim=1), torch.tensor(targets)) & ~unknown
    distance, nearest = distance_transform_edt(~surface.view(24, 24, 24).numpy(), return_indices=True)
    near = torch.as_tensor(distance.reshape(-1) * lattice.spacing <= radius) & unknown
    source = torch.as_tensor(np.ravel_multi_index(nearest.reshape(3, -1), (24, 24, 24)))
    expected = torch.where(near[:, None], F.one_hot(sem[source].argmax(dim=1), 7).to(sem.dtype), sem)
    assert 0 < int(near.sum()) < int(unknown.sum())  # some unknown rows change, others do not
    assert torch.equal(_unknown_near_targets_as_targets(lattice, occ, sem.clone(), unknown, targets, radius), expected)


class UniformClassSlabField(SlabField):
    """A slab with no class preferred (uniform class probabilities), as the marked unknown far from a target: deep
    enough that every ray through it saturates (its weights sum to 1 up to rounding)."""

    def query(self, x):
        out = super().query(x)
        inside = out["sem"][:, 0] == 0
        out["sem"][inside] = 1.0 / NUM_CLASSES
        return out


def test_a_saturated_ray_through_space_of_no_class_renders_as_background_not_as_a_target():
    """Rounding can make 1 - sum_i w_i a hair negative on a saturated ray, and the classes' equal shares differ in their
    last bits where the CPU's matrix kernel sums them in another order (an AMD EPYC); the background's share is clamped
    at 0 and a tie within ``CLASS_TIE`` goes to the background, never to class 1 (the car) by a rounding accident; the
    exploitation of a car target there is 0. A class ahead of the background by more than the tie still wins."""
    # o = 0.3: the weights' sum rounds above 1 on many rays (at o = 0.5 every product is a power of 2, exact); the
    # unclamped rule rendered 1375 of these 12288 rays as the car, the plain argmax 1404 on an AMD EPYC
    field = UniformClassSlabField(0.3, z0=-0.9, z1=0.9)
    k, views, n = Intrinsics.from_fov(32, 32, 60), fibonacci_hemisphere(12), 200
    out = render_uncertainty(field, k, [view_to_pose(*v) for v in views], n)
    sem = out["sem"]
    saturated = (sem.sum(dim=-1) - 1).abs() < 1e-5
    assert saturated.float().mean() > 0.2, "the test needs rays that saturate in the slab"
    assert torch.all(sem.max(dim=-1).values - sem[..., BACKGROUND] < CLASS_TIE / 10), "the shares are not a tie"
    assert torch.all(ray_classes(sem) == BACKGROUND), "a class other than the background won a tie"
    assert not target_mask(sem, (1,)).any()
    ahead = sem.clone()
    ahead[..., 1] += 2 * CLASS_TIE
    tied = (sem[..., 1] > 0.1) & ((sem[..., 1] - sem[..., BACKGROUND]).abs() < CLASS_TIE)  # saturated in the slab
    assert tied.any() and torch.all(ray_classes(ahead)[tied] == 1) and target_mask(ahead, (1,))[tied].all()
    assert np.all(score_views(field, views, (1,), k, n, UtilityOptions()).exploitation == 0)
