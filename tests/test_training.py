import copy
from dataclasses import replace

import numpy as np
import pytest
import torch

import stair_lite  # noqa: F401
from stair_lite.config import FieldConfig, RenderConfig, TrainConfig, get_preset
from stair_lite.evaluation import psnr
from stair_lite.field import SemanticField
from stair_lite.geometry import Intrinsics, view_to_pose
from stair_lite.measurement import Measurement
from stair_lite.rendering import render_image
from stair_lite.scenes import load_scene
from stair_lite.simulator import Simulator
from stair_lite.training import RayBuffer, Trainer, loss_terms

SMALL_FIELD = FieldConfig(grid_resolution=32, rgb_hidden=(32, 32))
SMALL_RENDER = RenderConfig(n_samples=32, n_surface_samples=8)
SMALL_TRAIN = TrainConfig(rays_new=256, rays_replay=256, iterations_per_view=40, lr_occupancy_head=0.05)
K = Intrinsics.from_fov(64, 64)


@pytest.fixture(scope="module")
def sim():
    return Simulator(load_scene("scene1"), K)


def measurement(sim, el, az):
    return sim.render(view_to_pose(el, az))


def test_training_lowers_the_loss_and_fits_the_view(sim):
    field = SemanticField(SMALL_FIELD, seed=0)
    trainer = Trainer(field, SMALL_TRAIN, SMALL_RENDER, seed=0)
    m = measurement(sim, 1.0, 0.5)
    before = render_image(field, K, m.pose, SMALL_RENDER)
    trainer.add_measurement(m)
    history = trainer.update(240)  # the linear occupancy head makes this coarse grid opaque: after 160, 13 cm depth error
    first, last = np.mean([h.total for h in history[:10]]), np.mean([h.total for h in history[-10:]])
    assert last < 0.5 * first
    after = render_image(field, K, m.pose, SMALL_RENDER)
    assert psnr(after["rgb"], m.rgb) > psnr(before["rgb"], m.rgb) + 5
    hit = m.depth > 0
    assert np.median(np.abs(after["depth"][hit] - m.depth[hit])) < 0.1


def test_training_is_deterministic_given_a_seed(sim):
    losses = []
    for _ in range(2):
        field = SemanticField(SMALL_FIELD, seed=1)
        trainer = Trainer(field, SMALL_TRAIN, SMALL_RENDER, seed=1)
        trainer.add_measurement(measurement(sim, 0.7, 1.0))
        trainer.add_measurement(measurement(sim, 0.4, 3.0))
        losses.append([h.total for h in trainer.update(5)])
    assert losses[0] == losses[1]


def test_replay_draws_distinct_old_rays_favouring_rarely_used_ones(sim):
    buffer = RayBuffer()
    buffer.add(measurement(sim, 1.0, 0.0))
    buffer.add(measurement(sim, 0.5, 2.0))
    n_old = K.width * K.height
    buffer.use_counts[: n_old // 2] = 9  # half of the old rays were used often
    draws = [buffer.replay_indices(500, np.random.default_rng(s)) for s in range(20)]
    for d in draws:
        assert len(np.unique(d)) == len(d) == 500
        assert d.max() < n_old  # only earlier views are replayed
    frequent = np.mean([np.mean(d < n_old // 2) for d in draws])
    # P proportional to 1 / (1 + count): 1/10 against 1/1 -> about 1/11 of draws from the frequent half
    assert frequent == pytest.approx(1 / 11, abs=0.02)


def test_first_view_has_no_replay_and_later_batches_mix_half_and_half(sim):
    field = SemanticField(SMALL_FIELD, seed=0)
    trainer = Trainer(field, SMALL_TRAIN, SMALL_RENDER, seed=0)
    trainer.add_measurement(measurement(sim, 1.0, 0.0))
    trainer.update(3)
    assert trainer.buffer.use_counts.sum() == 3 * 256
    trainer.add_measurement(measurement(sim, 0.5, 2.0))
    trainer.update(2)
    new = trainer.buffer.view_index == 1
    assert trainer.buffer.use_counts[new].sum() == 2 * 256
    assert trainer.buffer.use_counts[~new].sum() == 3 * 256 + 2 * 256


def test_empty_measurement_set_is_named():
    trainer = Trainer(SemanticField(SMALL_FIELD), SMALL_TRAIN, SMALL_RENDER)
    with pytest.raises(ValueError, match="measurement set is empty"):
        trainer.update()


def test_saturated_occupancy_gives_finite_loss_and_gradients(sim):
    field = SemanticField(SMALL_FIELD, seed=0)
    with torch.no_grad():
        field.occ_mlp[-1].bias.fill_(50.0)  # o == 1 everywhere: log(0) and 0 * inf lurk
        field.grid_app[:, -7:] = torch.tensor([-100.0, 100, -100, -100, -100, -100, -100])
    trainer = Trainer(field, SMALL_TRAIN, SMALL_RENDER, seed=0)
    trainer.add_measurement(measurement(sim, 0.8, 0.3))
    history = trainer.update(3)
    assert all(np.isfinite(h.total) for h in history)
    assert all(torch.all(torch.isfinite(p)) for p in field.parameters())


def test_loss_terms_follow_the_paper_weights():
    out = {"rgb": torch.zeros(2, 3), "depth": torch.zeros(2), "sem": torch.tensor([[1.0, 0, 0, 0, 0, 0, 0]] * 2)}
    batch = {"rgb": torch.ones(2, 3), "depth": torch.full((2,), 2.0), "labels": torch.tensor([0, 1])}
    cfg = get_preset("paper").train
    total, l_rgb, l_depth, l_sem = loss_terms(out, batch, cfg)
    assert l_rgb.item() == pytest.approx(3.0) and l_depth.item() == pytest.approx(2.0)
    assert l_sem.item() == pytest.approx(-np.log(1e-6) / 2)  # clamped log(0) on the second ray
    assert total.item() == pytest.approx(1.0 * 3.0 + 0.1 * 2.0 + 1.0 * l_sem.item())


def test_paper_preset_trains_on_cpu(sim):
    """The paper's field (128^3 grids, 2x128 / 2x32 MLPs, 200 samples) runs; rays are cut for CPU speed."""
    preset = get_preset("paper")
    field = SemanticField(preset.field, seed=0)
    trainer = Trainer(field, TrainConfig(rays_new=64, rays_replay=64), preset.render, seed=0)
    trainer.add_measurement(measurement(sim, 1.2, 0.0))
    history = trainer.update(2)
    assert all(np.isfinite(h.total) for h in history)


def test_bad_measurements_are_rejected_before_training(sim):
    m = measurement(sim, 1.0, 0.0)
    with pytest.raises(ValueError, match="depth contains"):
        Measurement(m.rgb, np.where(m.depth > 0, np.nan, 0).astype(np.float32), m.labels, m.pose, m.intrinsics)
    with pytest.raises(ValueError, match=r"rgb has shape \(10, 64, 3\)"):
        Measurement(m.rgb[:10], m.depth, m.labels, m.pose, m.intrinsics)
    with pytest.raises(ValueError, match="class range"):
        Measurement(m.rgb, m.depth, m.labels + 7, m.pose, m.intrinsics)


def test_a_batch_in_several_passes_has_the_gradient_of_one_pass(sim):
    """rays_per_pass changes memory, not the gradient: the passes' shares add up to the batch's gradient
    (samples without jitter, so that both see the same samples); the later passes add the grids' shares into
    their .grad in place."""
    from stair_lite.training import accumulate_gradient

    buffer = RayBuffer()
    buffer.add(measurement(sim, 0.6, 1.0))
    rays = buffer.rays(np.random.default_rng(0).choice(len(buffer), 500, replace=False))
    batch = {k: torch.as_tensor(v) for k, v in rays.items()}
    grads, terms = [], []
    for per_pass in (500, 64):  # one pass, or eight
        field = SemanticField(SMALL_FIELD, seed=0)
        with torch.no_grad():  # a field with some structure, so that every term has a gradient
            generator = torch.Generator().manual_seed(1)
            for grid in (field.grid_occ, field.grid_app):
                grid.normal_(0, 1.0, generator=generator)
            field.occ_mlp[-1].bias.fill_(3.0)  # occupancies around 0.05: colour and classes matter too
            field.reached.fill_(True)  # as if measurements had reached every cell
        terms.append(accumulate_gradient(field, batch, TrainConfig(rays_per_pass=per_pass), SMALL_RENDER))
        assert not field.grid_grad_into_existing  # the later passes' in-place adding ends with the batch
        grads.append([torch.zeros_like(p) if p.grad is None else p.grad.clone() for p in field.parameters()])
    torch.testing.assert_close(terms[0], terms[1], rtol=1e-5, atol=1e-6)
    for a, b in zip(*grads):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-6)
    assert all(g.abs().sum() > 0 for g in grads[0])


def test_training_skips_only_space_the_field_and_the_measurements_call_empty(sim):
    """The training skip grid keeps every cell where a measurement saw a surface, even where the field
    believes space is empty, and it leaves out cells where the field is empty and nothing was measured."""
    field = SemanticField(SMALL_FIELD, seed=0)
    trainer = Trainer(field, SMALL_TRAIN, SMALL_RENDER, seed=0)
    with torch.no_grad():
        field.occ_mlp[-1].bias.fill_(-30.0)  # o is about 0 everywhere: the field calls all space empty
    m = measurement(sim, 1.0, 0.0)
    trainer.add_measurement(m)
    trainer.update(1)
    from stair_lite.measurement import back_project

    surface = torch.as_tensor(back_project(m)[0], dtype=torch.float32)
    assert trainer.skip.lookup(surface).all()  # every measured surface point is in a kept cell
    assert trainer.skip.keep.float().mean() < 0.2  # most of the empty cube is skipped
    off = TrainConfig(**{**SMALL_TRAIN.__dict__, "skip_below": None})
    unskipped = Trainer(SemanticField(SMALL_FIELD, seed=0), off, SMALL_RENDER, seed=0)
    unskipped.add_measurement(m)
    unskipped.update(1)
    assert unskipped.skip is None


def test_a_measurement_marks_the_cells_its_rays_reached_and_none_behind_the_surfaces(sim):
    """``add_measurement`` marks the vertices of every cell a ray passed in front of its surface: no vertex more than
    one cell below the ground's top (z = 0) is marked after the top view, every vertex of a surface point's cell is,
    and a cell no ray reached has zero occupancy, while the head decides in the cells rays reached."""
    field = SemanticField(replace(SMALL_FIELD, reached_only=True), seed=0)
    trainer = Trainer(field, SMALL_TRAIN, SMALL_RENDER, seed=0)
    points = field.lattice.points()
    assert not field.reached.any() and float(field.query(points)["occ"].max()) == 0.0  # a new field knows nothing: empty
    m = measurement(sim, np.pi / 2, 0.0)  # the top view
    trainer.add_measurement(m)
    spacing = field.lattice.spacing
    assert points[field.reached, 2].min() > -spacing - 1e-6  # nothing beyond the cell that holds the ground's top
    from stair_lite.field import corner_indices_and_weights
    from stair_lite.measurement import back_project

    surface = torch.as_tensor(back_project(m)[0], dtype=torch.float32)
    camera = torch.as_tensor(m.pose[:3, 3], dtype=torch.float32)
    inside = lambda p: p[(p.abs() < field.lattice.bound).all(dim=1)]  # noqa: E731
    for point in (surface, inside(0.5 * (surface + camera))):  # the surface points, and halfway to them in the cube
        corners, _ = corner_indices_and_weights(field.lattice.normalise(point), field.lattice.resolution)
        assert field.reached[corners].all()
    with torch.no_grad():
        field.occ_mlp[-1].bias.fill_(50.0)  # the head says o = 1 everywhere
    occ = field.query(points)["occ"]
    assert occ[~field.reached].max() < 1e-4 and torch.all(occ[points[:, 2] < -2 * spacing] == 0)  # (float rounding)
    assert torch.allclose(occ[field.reached & (points[:, 2] > 0.5)], torch.ones(1))
    plain = SemanticField(replace(SMALL_FIELD, reached_only=False), seed=0)
    with torch.no_grad():
        plain.occ_mlp[-1].bias.fill_(50.0)
    assert torch.allclose(plain.query(points)["occ"], torch.ones(1))  # off: the head everywhere, as the paper


def test_the_skip_grid_is_rebuilt_after_a_measurement_and_every_refresh_not_every_call(monkeypatch):
    """Updates of one iteration each rebuild the skip grid as one long update does: at the start (a new measurement)
    and then every ``skip_refresh`` iterations, counted across calls."""
    import stair_lite.training as training

    builds = []
    real = training.build_skip_grid
    monkeypatch.setattr(training, "build_skip_grid", lambda *a, **kw: builds.append(1) or real(*a, **kw))
    sim = Simulator(load_scene("scene1"), Intrinsics.from_fov(40, 40))
    trainer = Trainer(SemanticField(SMALL_FIELD), replace(SMALL_TRAIN, skip_refresh=5), SMALL_RENDER)
    trainer.add_measurement(sim.render(view_to_pose(np.pi / 2, 0.0)))
    for _ in range(12):
        trainer.update(1)
    assert len(builds) == 3  # at iterations 0, 5 and 10
    trainer.add_measurement(sim.render(view_to_pose(0.6, 1.0)))
    trainer.update(1)
    assert len(builds) == 4  # a new measurement: rebuilt at once


class _StockAdam(torch.optim.Adam):
    """torch's fused Adam over every row, with the trainer's live-row calls ignored: the reference for GridAdam."""

    def mark_live(self, rows=None):
        pass


def test_grid_adam_trains_bit_for_bit_as_torch_adam_while_visiting_only_live_rows(sim):
    """The trainer's optimiser (GridAdam) steps only the grid rows near cells the skip grid kept; torch's fused Adam
    over every row gives the same losses, parameters and moments bit for bit, the rows left out have zero moments,
    and they are most of the grid (so the comparison is not trivially over the same rows)."""
    cfg = replace(SMALL_TRAIN, skip_refresh=10)
    trainers = []
    for stock in (False, True):
        field = SemanticField(replace(SMALL_FIELD, reached_only=True), seed=0)
        trainer = Trainer(field, cfg, SMALL_RENDER, seed=0)
        if stock:
            trainer.optimizer = _StockAdam(field.param_groups(cfg), betas=(0.9, 0.99), fused=True)
        losses = []
        for el, az in ((1.0, 0.5), (0.6, 2.5)):
            trainer.add_measurement(measurement(sim, el, az))
            losses += [h.total for h in trainer.update(25)]
        trainers.append((trainer, losses))
    (grid_trainer, grid_losses), (stock_trainer, stock_losses) = trainers
    assert grid_losses == stock_losses
    for a, b in zip(grid_trainer.field.parameters(), stock_trainer.field.parameters()):
        assert torch.equal(a, b)
    optimiser = grid_trainer.optimizer
    for grid, stock_grid in zip(optimiser.grids, (stock_trainer.field.grid_occ, stock_trainer.field.grid_app)):
        for moment in ("exp_avg", "exp_avg_sq"):
            assert torch.equal(optimiser.state[grid][moment], stock_trainer.optimizer.state[stock_grid][moment])
            assert not optimiser.state[grid][moment][~optimiser.live_rows].any()
    covered = sum(stop - start for start, stop in optimiser.spans) / len(optimiser.live_rows)
    assert covered < 0.6


def test_grid_adam_continues_from_a_state_dict_with_the_rows_it_had_visited(sim):
    """A trainer restored from a state dict marks as live every row whose moments are not zero (fewer than training
    marked: those near kept cells): it continues exactly as the trainer it was saved from."""
    trainers = []
    for _ in range(2):
        trainer = Trainer(SemanticField(replace(SMALL_FIELD, reached_only=True), seed=0), SMALL_TRAIN, SMALL_RENDER, seed=0)
        trainer.add_measurement(measurement(sim, 1.0, 0.5))
        trainers.append(trainer)
    first, second = trainers
    first.update(15)
    second.field.load_state_dict(first.field.state_dict())
    second.load_state_dict(copy.deepcopy(first.state_dict()))  # (torch's optimiser state dict holds the live moments)
    restored, marked = second.optimizer.live_rows, first.optimizer.live_rows
    assert restored.any() and not (restored & ~marked).any()  # the rows with moments: within the rows marked in training
    m = measurement(sim, 0.6, 2.5)
    for trainer in trainers:
        trainer.add_measurement(m)
    assert [h.total for h in first.update(10)] == [h.total for h in second.update(10)]


def test_an_update_leaves_no_gradient_table_and_the_next_one_trains_as_with_a_zeroed_table(sim):
    """Between updates the grids hold no gradient table (one is as large as its grid: planning and evaluation run
    without them); the next update starts a zero table, and trains bit for bit as a trainer whose tables were kept,
    zeroed, between its updates."""
    trainers = []
    for keep in (False, True):
        field = SemanticField(replace(SMALL_FIELD, reached_only=True), seed=0)
        trainer, losses = Trainer(field, SMALL_TRAIN, SMALL_RENDER, seed=0), []
        for el, az in ((1.0, 0.5), (0.6, 2.5)):
            trainer.add_measurement(measurement(sim, el, az))
            for _ in range(2):
                losses += [h.total for h in trainer.update(6)]
                assert field.grid_occ.grad is None and field.grid_app.grad is None
                if keep:
                    for grid in (field.grid_occ, field.grid_app):
                        grid.grad = torch.zeros_like(grid)
        trainers.append((trainer, losses))
    (dropped, dropped_losses), (kept, kept_losses) = trainers
    assert dropped_losses == kept_losses
    for a, b in zip(dropped.field.parameters(), kept.field.parameters()):
        assert torch.equal(a, b)

