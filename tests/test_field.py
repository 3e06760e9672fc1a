from dataclasses import replace

import pytest
import torch
import torch.nn.functional as F

from stair_lite.config import FieldConfig, get_preset
from stair_lite.field import SemanticField, positional_encoding, trilinear


def test_trilinear_matches_grid_sample_values_and_gradients():
    gen = torch.Generator().manual_seed(0)
    r, c = 6, 5
    table = torch.randn(r**3, c, generator=gen, dtype=torch.float64, requires_grad=True)
    grid = table.detach().t().reshape(1, c, r, r, r).clone().requires_grad_(True)
    x = torch.rand(500, 3, generator=gen, dtype=torch.float64) * 2 - 1
    ours = trilinear(table, r, x)
    ref = F.grid_sample(grid, x.view(1, 1, 1, -1, 3), align_corners=True).view(c, -1).t()
    torch.testing.assert_close(ours, ref)
    weights = torch.randn(500, c, generator=gen, dtype=torch.float64)
    (ours * weights).sum().backward()
    (ref * weights).sum().backward()
    torch.testing.assert_close(table.grad, grid.grad.reshape(c, -1).t())


def test_trilinear_is_exact_at_vertices_and_for_linear_fields():
    r = 5
    axis = torch.linspace(-1, 1, r, dtype=torch.float64)
    z, y, x = torch.meshgrid(axis, axis, axis, indexing="ij")
    linear = (0.3 * x - 2 * y + 0.5 * z + 1).reshape(-1, 1)
    pts = torch.rand(200, 3, dtype=torch.float64, generator=torch.Generator().manual_seed(1)) * 2 - 1
    expected = 0.3 * pts[:, 0] - 2 * pts[:, 1] + 0.5 * pts[:, 2] + 1
    torch.testing.assert_close(trilinear(linear, r, pts)[:, 0], expected)
    vertex = torch.tensor([[axis[1], axis[3], axis[2]]])
    torch.testing.assert_close(trilinear(linear, r, vertex)[0, 0], linear[(2 * r + 3) * r + 1, 0])


def test_positional_encoding_maps_to_21_dimensions():
    x = torch.tensor([[0.5, -0.25, 1.0]])
    g = positional_encoding(x, 3)
    assert g.shape == (1, 21)
    torch.testing.assert_close(g[0, :3], x[0])
    torch.testing.assert_close(g[0, 3:6], torch.sin(x[0]))  # k = 0
    torch.testing.assert_close(g[0, 6:9], torch.sin(2 * x[0]))  # k = 1
    torch.testing.assert_close(g[0, 12:15], torch.cos(x[0]))


@pytest.mark.parametrize("preset", ["lite", "paper"])
def test_field_outputs_have_the_paper_ranges(preset):
    cfg = get_preset(preset).field
    field = SemanticField(cfg, seed=0)
    x = (torch.rand(1000, 3, generator=torch.Generator().manual_seed(2)) * 2 - 1) * cfg.bound
    out = field(x)
    assert out["occ"].shape == (1000,) and out["rgb"].shape == (1000, 3) and out["sem_logits"].shape == (1000, 7)
    assert out["occ"].min() >= 0 and out["occ"].max() <= 1
    assert out["occ"].max() < 0.01  # the map starts almost empty
    assert out["rgb"].min() >= 0 and out["rgb"].max() <= 1
    assert field.V_occ.shape == (cfg.occ_channels,) + (cfg.grid_resolution,) * 3
    assert field.V_rgb.shape[0] == cfg.rgb_channels and field.V_sem.shape[0] == cfg.sem_channels
    if preset == "paper":
        assert cfg.grid_resolution == 128 and cfg.rgb_hidden == (128, 128) and cfg.occ_hidden == ()  # README: the head
        assert (cfg.occ_channels, cfg.rgb_channels, cfg.sem_channels) == (3, 6, 7)


def test_grid_views_name_the_right_channels():
    field = SemanticField(FieldConfig(grid_resolution=4), seed=0)
    with torch.no_grad():
        field.grid_app[(1 * 4 + 2) * 4 + 3, 0] = 7.0  # vertex x=3, y=2, z=1, first rgb channel
    assert field.V_rgb[0, 1, 2, 3] == 7.0
    assert field.V_occ.abs().sum() == 0 and field.V_sem.abs().sum() == 0


def test_field_initialisation_is_seeded():
    a, b = SemanticField(FieldConfig(grid_resolution=8), seed=3), SemanticField(FieldConfig(grid_resolution=8), seed=3)
    for pa, pb in zip(a.parameters(), b.parameters()):
        torch.testing.assert_close(pa, pb)
    c = SemanticField(FieldConfig(grid_resolution=8), seed=4)
    assert not torch.equal(a.rgb_mlp[0].weight, c.rgb_mlp[0].weight)  # (the linear occupancy head starts at 0.1)


def test_saturated_occupancy_stays_finite():
    field = SemanticField(FieldConfig(grid_resolution=8), seed=0)
    with torch.no_grad():
        field.occ_mlp[-1].bias.fill_(1e4)
    field.reached.fill_(True)  # as if measurements had reached every cell (a new field is empty everywhere)
    occ = field(torch.zeros(10, 3))["occ"]
    assert torch.all(occ == 1.0) and torch.all(torch.isfinite(occ))


def test_unknown_preset_is_named():
    with pytest.raises(ValueError, match="unknown preset 'huge'"):
        get_preset("huge")


@pytest.mark.parametrize("name", ["paper", "lite", "smoke"])
def test_every_preset_gives_both_maps_one_grid_and_refuses_two(name):
    """The paper compares the field and the voxel map at one grid size (Sec. IV-C): every preset does, and a preset
    whose voxel map has another grid is refused with both sizes named."""
    from dataclasses import replace

    from stair_lite.config import ExplicitConfig

    preset = get_preset(name)
    assert preset.explicit.resolution == preset.field.grid_resolution
    with pytest.raises(ValueError, match=rf"voxel map's grid \(12\^3\) must equal the field's \({preset.field.grid_resolution}"):
        replace(preset, explicit=ExplicitConfig(resolution=12))


def test_occupancy_head_reads_no_raw_position():
    """The occupancy head reads the grid features and the sin/cos terms of gamma, not x itself (README, "No
    phantom"); the colour head reads all of gamma."""
    field = SemanticField(get_preset("lite").field, seed=0)
    f_occ = torch.randn(50, 3, generator=torch.Generator().manual_seed(0))
    pe = torch.randn(50, 21, generator=torch.Generator().manual_seed(1))
    moved = pe.clone()
    moved[:, :3] += 1.0
    torch.testing.assert_close(field.occupancy_from(f_occ, pe), field.occupancy_from(f_occ, moved))
    f_rgb = torch.randn(50, 6, generator=torch.Generator().manual_seed(2))
    assert not torch.allclose(field.colour_from(f_rgb, pe), field.colour_from(f_rgb, moved))


def test_an_occupancy_head_without_position_reads_the_grid_features_only():
    """``occ_reads_position=False``: the head is a function of f_occ alone (README, "No phantom": the position
    terms of the default head fill volume no ray reached); the default head's sin/cos terms move it."""
    lite = get_preset("lite").field
    f_occ = torch.randn(50, 3, generator=torch.Generator().manual_seed(0))
    pe = torch.randn(50, 21, generator=torch.Generator().manual_seed(1))
    moved = pe + 1.0
    grid_only = SemanticField(replace(lite, occ_reads_position=False), seed=0)
    assert grid_only.occ_mlp[0].in_features == lite.occ_channels
    torch.testing.assert_close(grid_only.occupancy_from(f_occ, pe), grid_only.occupancy_from(f_occ, moved))
    default = SemanticField(lite, seed=0)
    assert not torch.allclose(default.occupancy_from(f_occ, pe), default.occupancy_from(f_occ, moved))


@pytest.mark.parametrize("hidden", [(), (8,), (16, 16)])
def test_an_mlp_on_parts_is_the_mlp_on_their_concatenation(hidden):
    """The heads read (features, gamma) without concatenating them: the same values and the same gradients."""
    from stair_lite.field import mlp, mlp_on_parts

    torch.manual_seed(0)
    net = mlp(9, hidden, 2)
    a, b = torch.randn(50, 3, requires_grad=True), torch.randn(50, 6)
    whole, split = net(torch.cat([a, b], dim=1)), mlp_on_parts(net, a, b)
    torch.testing.assert_close(split, whole)
    grad_whole = torch.autograd.grad(whole.sum(), [a, net[0].weight])
    grad_split = torch.autograd.grad(split.sum(), [a, net[0].weight])
    for g_split, g_whole in zip(grad_split, grad_whole):
        torch.testing.assert_close(g_split, g_whole)


@pytest.mark.parametrize("hidden", [(), (8,), (128, 128)])
def test_an_mlp_in_blocks_gives_the_rows_of_the_whole_batch(hidden):
    """Inference in cache-sized blocks with the ReLUs in place: the same rows as ``mlp_on_parts`` over the whole batch,
    for a batch that is not a multiple of the block, and the field's colour alike with and without gradients."""
    from stair_lite.field import mlp, mlp_on_parts, mlp_on_parts_in_blocks

    torch.manual_seed(0)
    net = mlp(27, hidden, 3)
    a, b = torch.randn(10_001, 6), torch.randn(10_001, 21)
    with torch.no_grad():
        whole = mlp_on_parts(net, a, b)
    torch.testing.assert_close(mlp_on_parts_in_blocks(net, a, b, rows=4096), whole, rtol=0, atol=1e-6)
    torch.testing.assert_close(mlp_on_parts_in_blocks(net, a, b, rows=7), whole, rtol=0, atol=1e-6)
    with pytest.raises(ValueError, match="linear layers with a ReLU"):
        mlp_on_parts_in_blocks(torch.nn.Sequential(torch.nn.Linear(27, 3), torch.nn.Tanh(), torch.nn.Linear(3, 3)), a, b)
    field = SemanticField(get_preset("paper").field, seed=0)
    f_rgb, pe = torch.randn(5000, field.cfg.rgb_channels), torch.randn(5000, 21)
    with torch.no_grad():
        blocked = field.colour_from(f_rgb, pe)
    torch.testing.assert_close(blocked, field.colour_from(f_rgb, pe).detach(), rtol=0, atol=1e-6)

