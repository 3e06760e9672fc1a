"""The checkers of notebook 02's exercises accept a correct answer and reject plausible wrong ones."""
import numpy as np
import pytest
import torch

from stair_lite.exercises.field import (check_batch_loss, check_composite, check_training_step,
                                       check_transmittance_and_weights)
from stair_lite.training import LOG_CLAMP, loss_terms
from stair_lite.rendering import compositing_weights


# ---- exercise 1: transmittance and weights ------------------------------------------------------
def weights_ok(occ):
    T = np.cumprod(np.c_[np.ones(len(occ)), 1.0 - occ[:, :-1]], axis=1)
    return T, occ * T


def weights_stair_lite(occ):
    w, T = compositing_weights(torch.as_tensor(occ))
    return T.numpy(), w.numpy()


def weights_inclusive(occ):
    T = np.cumprod(1.0 - occ, axis=1)
    return T, occ * T


def weights_no_o(occ):
    T, _ = weights_ok(occ)
    return T, T


def weights_cumprod_o(occ):
    T = np.cumprod(np.c_[np.ones(len(occ)), occ[:, :-1]], axis=1)
    return T, occ * T


def weights_swapped(occ):
    T, w = weights_ok(occ)
    return w, T


def weights_stub(occ):
    return None


def test_transmittance_accepts_correct():
    assert check_transmittance_and_weights(weights_ok)
    assert check_transmittance_and_weights(weights_stair_lite)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (weights_inclusive, "INCLUSIVE"),
        (weights_no_o, "forgot the factor o_i"),
        (weights_cumprod_o, r"\(1 - o_j\)"),
        (weights_swapped, "you returned \\(weights, transmittance\\)"),
        (weights_stub, "None"),
    ],
)
def test_transmittance_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_transmittance_and_weights(wrong)


def composite_ok(weights, t, colours):
    acc = weights.sum(axis=1)
    return (weights[..., None] * colours).sum(axis=1) + (1 - acc)[:, None], (weights * t).sum(axis=1)


def composite_black_background(weights, t, colours):
    return (weights[..., None] * colours).sum(axis=1), (weights * t).sum(axis=1)


def composite_normalised_depth(weights, t, colours):
    rgb, _ = composite_ok(weights, t, colours)
    return rgb, (weights * t).sum(axis=1) / np.maximum(weights.sum(axis=1), 1e-12)


def composite_mean_depth(weights, t, colours):
    rgb, _ = composite_ok(weights, t, colours)
    return rgb, t.mean(axis=1)


def composite_argmax_depth(weights, t, colours):
    rgb, _ = composite_ok(weights, t, colours)
    return rgb, t[np.arange(len(t)), weights.argmax(axis=1)]


def test_composite_accepts_correct():
    assert check_composite(composite_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (composite_black_background, "white background"),
        (composite_normalised_depth, "do not divide"),
        (composite_mean_depth, "WEIGHTED"),
        (composite_argmax_depth, "heaviest"),
    ],
)
def test_composite_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_composite(wrong)


def stub_raising(*args):
    raise NotImplementedError


@pytest.mark.parametrize("checker", [check_transmittance_and_weights, check_composite, check_batch_loss, check_training_step])
def test_checkers_explain_an_untouched_stub(checker):
    with pytest.raises(AssertionError, match="NotImplementedError"):
        checker(stub_raising)


# ---- exercise 3: the loss of a batch and one training step -------------------------------------
def loss_ok(rendered, measured, lambdas, log_clamp):
    l_rgb = ((rendered["rgb"] - measured["rgb"]) ** 2).sum(dim=1).mean()
    l_depth = (rendered["depth"] - measured["depth"]).abs().mean()
    picked = rendered["sem"][torch.arange(len(measured["labels"])), measured["labels"]]
    return lambdas[0] * l_rgb + lambdas[1] * l_depth + lambdas[2] * -torch.log(picked.clamp(min=log_clamp)).mean()


def loss_stair_lite(rendered, measured, lambdas, log_clamp):
    class Weights:
        lambda_rgb, lambda_depth, lambda_sem = lambdas
    assert log_clamp == LOG_CLAMP
    return loss_terms(rendered, measured, Weights)[0]


def loss_channel_mean(rendered, measured, lambdas, log_clamp):
    l_rgb = ((rendered["rgb"] - measured["rgb"]) ** 2).mean()
    return loss_ok(rendered, measured, lambdas, log_clamp) + lambdas[0] * (
        l_rgb - ((rendered["rgb"] - measured["rgb"]) ** 2).sum(dim=1).mean())


def loss_norm(rendered, measured, lambdas, log_clamp):
    d = rendered["rgb"] - measured["rgb"]
    return loss_ok(rendered, measured, lambdas, log_clamp) + lambdas[0] * (
        torch.sqrt((d ** 2).sum(dim=1)).mean() - (d ** 2).sum(dim=1).mean())


def loss_depth_squared(rendered, measured, lambdas, log_clamp):
    d = rendered["depth"] - measured["depth"]
    return loss_ok(rendered, measured, lambdas, log_clamp) + lambdas[1] * ((d ** 2).mean() - d.abs().mean())


def loss_hit_only(rendered, measured, lambdas, log_clamp):
    d = (rendered["depth"] - measured["depth"]).abs()
    hit = measured["depth"] > 0
    return loss_ok(rendered, measured, lambdas, log_clamp) + lambdas[1] * (d[hit].mean() - d.mean())


def loss_sum(rendered, measured, lambdas, log_clamp):
    return loss_ok(rendered, measured, lambdas, log_clamp) * len(measured["labels"])


def loss_no_clamp(rendered, measured, lambdas, log_clamp):
    return loss_ok(rendered, measured, lambdas, 0.0)


def loss_lambdas_reversed(rendered, measured, lambdas, log_clamp):
    return loss_ok(rendered, measured, lambdas[::-1], log_clamp)


def loss_detached(rendered, measured, lambdas, log_clamp):
    return torch.tensor(float(loss_ok(rendered, measured, lambdas, log_clamp).detach()))


def test_batch_loss_accepts_correct():
    assert check_batch_loss(loss_ok)
    assert check_batch_loss(loss_stair_lite)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (loss_channel_mean, "sums the squared error over the 3 channels"),
        (loss_norm, "SQUARED error"),
        (loss_depth_squared, "ABSOLUTE error"),
        (loss_hit_only, "teach free space"),
        (loss_sum, "MEAN over the batch"),
        (loss_no_clamp, "clamp the probability"),
        (loss_lambdas_reversed, "in that order"),
        (loss_detached, "gradients do not flow"),
    ],
)
def test_batch_loss_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_batch_loss(wrong)


def step_ok(model, optimizer, render, loss_fn, batch):
    loss = loss_fn(render(model, batch), batch)
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
    return loss.item()


def step_no_zero_grad(model, optimizer, render, loss_fn, batch):
    loss = loss_fn(render(model, batch), batch)
    loss.backward()
    optimizer.step()
    return loss.item()


def step_zero_grad_before_step(model, optimizer, render, loss_fn, batch):
    loss = loss_fn(render(model, batch), batch)
    loss.backward()
    optimizer.zero_grad()
    optimizer.step()
    return loss.item()


def step_no_step(model, optimizer, render, loss_fn, batch):
    loss = loss_fn(render(model, batch), batch)
    optimizer.zero_grad()
    loss.backward()
    return loss.item()


def step_returns_tensor(model, optimizer, render, loss_fn, batch):
    loss = loss_fn(render(model, batch), batch)
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
    return loss


def step_loss_after(model, optimizer, render, loss_fn, batch):
    step_ok(model, optimizer, render, loss_fn, batch)
    with torch.no_grad():
        return float(loss_fn(render(model, batch), batch))


def test_training_step_accepts_correct():
    assert check_training_step(step_ok)


@pytest.mark.parametrize(
    "wrong, hint",
    [
        (step_no_zero_grad, "ADD UP"),
        (step_zero_grad_before_step, "did not change"),
        (step_no_step, "did not change"),
        (step_returns_tensor, "Python float"),
        (step_loss_after, "BEFORE the optimiser step"),
    ],
)
def test_training_step_rejects_wrong(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_training_step(wrong)


# ---- trilinear interpolation ---------------------------------------------------------------------
from stair_lite.exercises.field import check_trilinear  # noqa: E402


def trilinear_grid_sample(V, x, bound=1.0):
    import torch.nn.functional as F

    grid = torch.as_tensor(V).permute(3, 2, 1, 0)[None]
    out = F.grid_sample(grid, torch.as_tensor(x / bound).view(1, 1, 1, -1, 3), mode="bilinear", align_corners=True)
    return out.view(V.shape[-1], -1).T.numpy()


def trilinear_by_edges(V, x, bound=1.0, centres=False, swap=False, reverse=False, nearest=False):
    r = V.shape[0]
    if reverse:
        V = V.transpose(2, 1, 0, 3)
    p = (x + bound) / (2 * bound) * (r if centres else r - 1) - (0.5 if centres else 0.0)
    if nearest:
        i = np.clip(np.round(p), 0, r - 1).astype(int)
        return V[i[:, 0], i[:, 1], i[:, 2]]
    i0 = np.clip(np.floor(p), 0, r - 2).astype(int)
    f = np.clip(p - i0, 0, 1)
    if swap:
        f = 1 - f

    def lerp(a, b, t):
        return a + t[:, None] * (b - a)

    i, j, k = i0.T
    fx, fy, fz = f.T
    c = [[lerp(V[i, j + dj, k + dk], V[i + 1, j + dj, k + dk], fx) for dj in (0, 1)] for dk in (0, 1)]
    return lerp(lerp(c[0][0], c[0][1], fy), lerp(c[1][0], c[1][1], fy), fz)


def test_trilinear_accepts_grid_sample_and_the_edge_by_edge_form():
    assert check_trilinear(trilinear_grid_sample)
    assert check_trilinear(trilinear_by_edges)


@pytest.mark.parametrize("wrong, hint", [
    (dict(nearest=True), "nearest vertex"),
    (dict(centres=True), "align_corners"),
    (dict(swap=True), "swapped"),
    (dict(reverse=True), "first index"),
])
def test_trilinear_rejects_plausible_mistakes(wrong, hint):
    with pytest.raises(AssertionError, match=hint):
        check_trilinear(lambda V, x, bound: trilinear_by_edges(V, x, bound, **wrong))


def test_trilinear_rejects_a_last_cell_out_of_range():
    def no_clamp(V, x, bound):
        r = V.shape[0]
        p = (x + bound) / (2 * bound) * (r - 1)
        i0 = np.floor(p).astype(int)
        return trilinear_by_edges(V, x, bound) if (i0 <= r - 2).all() else V[np.minimum(i0[:, 0], r - 1), 0, 0]

    with pytest.raises(AssertionError, match="trilinear is wrong"):
        check_trilinear(no_clamp)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_trilinear_checks_every_upper_face_not_only_the_corners(axis):
    """An answer wrong on one upper face of the cube away from its corners (a last cell mishandled along one axis)."""
    def wrong_on_one_face(V, x, bound):
        right = trilinear_by_edges(V, x, bound)
        on_face = np.isclose(x[:, axis], bound) & ~np.isclose(np.abs(x), bound).all(axis=1)
        return np.where(on_face[:, None], 0.0, right)

    with pytest.raises(AssertionError, match="trilinear is wrong"):
        check_trilinear(wrong_on_one_face)
