"""Checkers for the exercises of notebook 02 (the voxel occupancy field).

Each ``check_*`` takes the learner's function, calls it on seeded random inputs (and a few hand-picked
edge cases), compares the answers with an independent computation written here in plain numpy, and
raises ``AssertionError`` with a hint when they differ. Where a wrong answer matches a common mistake
(an inclusive instead of exclusive product, a missing white background, a loss summed instead of
averaged, gradients left to add up across steps, ...) the hint names that mistake. On success a checker prints one line and returns ``True``.
"""
from __future__ import annotations

import numpy as np
import torch

from .common import as_array as _as_array, call as _call, compares_with, diagnose

_ATOL = 1e-6


def _pair(out, what: str):
    if out is None:
        raise AssertionError(f"{what} returned None: fill in the function body (it still looks like the stub)")
    if not isinstance(out, tuple) or len(out) != 2:
        raise AssertionError(f"{what} must return a tuple of two arrays")
    return out


def _close(a, b, atol: float = _ATOL) -> bool:
    return bool(np.allclose(a, b, atol=atol, rtol=1e-7))


def _random_occupancies(rng: np.random.Generator, rays: int, samples: int) -> np.ndarray:
    """Occupancies in [0, 1] with exact zeros and ones mixed in, so that edge cases occur."""
    occ = rng.uniform(0.0, 1.0, size=(rays, samples)) ** rng.uniform(0.5, 4.0, size=(rays, 1))
    occ[rng.uniform(size=occ.shape) < 0.1] = 0.0
    occ[rng.uniform(size=occ.shape) < 0.02] = 1.0
    return occ


# --------------------------------------------------------------------------------------------------
# Exercise 1: transmittance and weights from occupancies (Eq. 5)
# --------------------------------------------------------------------------------------------------
def _weights_reference(occ: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    transmittance = np.ones_like(occ)
    for i in range(1, occ.shape[1]):
        transmittance[:, i] = transmittance[:, i - 1] * (1.0 - occ[:, i - 1])
    return transmittance, occ * transmittance


def _weights_hint(occ, T, w) -> str:
    want_T, want_w = _weights_reference(occ)
    inclusive = np.cumprod(1.0 - occ, axis=1)
    if _close(T, inclusive):
        return ("your transmittance is the INCLUSIVE product prod_{j<=i} (1 - o_j): T_i must stop before sample i "
                "(T_1 = 1, the ray always reaches its first sample)")
    if _close(T, np.cumprod(occ, axis=1)) or _close(T, np.cumprod(np.c_[np.ones(len(occ)), occ[:, :-1]], axis=1)):
        return "the transmittance multiplies (1 - o_j), the probability of passing sample j, not o_j"
    if _close(T, want_T) and _close(w, want_T):
        return "the weight is w_i = o_i * T_i: you forgot the factor o_i"
    if _close(T, want_T) and _close(w, (1.0 - occ) * want_T):
        return "the weight is w_i = o_i * T_i (stopped AT sample i), not (1 - o_i) * T_i"
    if _close(T, want_w) and _close(w, want_T):
        return "you returned (weights, transmittance): return (transmittance, weights)"
    if _close(T, want_T):
        return "the transmittance is right; the weight is w_i = o_i * T_i"
    return "T_i = prod_{j<i} (1 - o_j) (an exclusive cumulative product, T_1 = 1) and w_i = o_i * T_i"


@compares_with(_weights_reference)
def check_transmittance_and_weights(transmittance_and_weights, n_trials: int = 20, seed: int = 0) -> bool:
    """``transmittance_and_weights(occ)`` takes occupancies (R, S) in [0, 1] (R rays, S samples each, in
    order along the ray) and returns ``(T, w)``, both (R, S): T_i = prod_{j<i} (1 - o_j), w_i = o_i T_i."""
    rng = np.random.default_rng(seed)
    cases = [np.array([[0.0, 0.0, 1.0, 0.5]]), np.array([[0.3, 0.3, 0.3, 0.3, 0.3]]), np.zeros((2, 3))]
    for _ in range(n_trials):
        cases.append(_random_occupancies(rng, int(rng.integers(1, 20)), int(rng.integers(2, 60))))
    for occ in cases:
        T, w = _pair(_call(transmittance_and_weights, occ.copy()), "transmittance_and_weights(occ)")
        T = _as_array(T, occ.shape, "transmittance_and_weights(occ)[0] (T)")
        w = _as_array(w, occ.shape, "transmittance_and_weights(occ)[1] (w)")
        want_T, want_w = _weights_reference(occ)
        if _close(T, want_T) and _close(w, want_w):
            continue
        r = int(np.argmax(np.abs(T - want_T).sum(axis=1) + np.abs(w - want_w).sum(axis=1)))
        raise AssertionError(
            f"transmittance_and_weights is wrong for the ray with occupancies {np.round(occ[r, :6], 3)}...:\n"
            f"T = {np.round(T[r, :6], 4)}..., expected {np.round(want_T[r, :6], 4)}...\n"
            f"w = {np.round(w[r, :6], 4)}..., expected {np.round(want_w[r, :6], 4)}...\n"
            f"Hint: {_weights_hint(occ, T, w)}"
        )
    print(f"check_transmittance_and_weights: {len(cases)} batches of rays agree (including o = 0 and o = 1)")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 2: compositing colour and depth, with the white background
# --------------------------------------------------------------------------------------------------
def _composite_reference(weights, t, colours):
    acc = weights.sum(axis=1)
    rgb = (weights[..., None] * colours).sum(axis=1) + (1.0 - acc)[:, None]
    return rgb, (weights * t).sum(axis=1)


def _composite_hint(weights, t, colours, rgb, depth) -> str:
    want_rgb, want_depth = _composite_reference(weights, t, colours)
    acc = weights.sum(axis=1)
    if _close(rgb, want_rgb - (1.0 - acc)[:, None]):
        return "the part of the ray that hits nothing (1 - sum w) shows the white background: add (1 - sum_i w_i) to each channel"
    if _close(rgb, want_rgb) and _close(depth, want_depth / np.maximum(acc, 1e-12)):
        return ("do not divide the depth by sum w: a ray that hits nothing must render depth 0, like the measurement "
                "(the paper's D = sum_i w_i d_i)")
    if _close(rgb, want_rgb) and _close(depth, t.mean(axis=1)):
        return "the depth is the WEIGHTED sum sum_i w_i t_i, not the mean of the sample positions"
    if _close(rgb, want_rgb) and _close(depth, t[np.arange(len(t)), weights.argmax(axis=1)]):
        return "that is the depth of the heaviest sample; the rendered depth is the expectation sum_i w_i t_i"
    if _close(rgb, want_rgb):
        return "the colour is right; the depth is D = sum_i w_i t_i"
    return ("compare with Eqs. 2-3 on a ray of one sample of weight 0.5: the colour it adds, what shows through the rest, "
            "and the depth")


@compares_with(_composite_reference)
def check_composite(composite, n_trials: int = 20, seed: int = 0) -> bool:
    """``composite(weights, t, colours)`` takes weights (R, S) (with sum_i w_i <= 1 per ray), sample depths
    t (R, S) and sample colours (R, S, 3) and returns ``(rgb, depth)``: rgb (R, 3) = sum_i w_i c_i plus
    the white background for the part of the ray that hits nothing, and depth (R,) = sum_i w_i t_i."""
    rng = np.random.default_rng(seed)
    for trial in range(n_trials):
        r, s = int(rng.integers(1, 20)), int(rng.integers(2, 50))
        occ = _random_occupancies(rng, r, s) * rng.uniform(0.0, 1.0, size=(r, 1))
        occ[0] = 0.0  # a ray that hits nothing
        _, weights = _weights_reference(occ)
        t = np.sort(rng.uniform(0.2, 3.5, size=(r, s)), axis=1)
        colours = rng.uniform(0.0, 1.0, size=(r, s, 3))
        out = _pair(_call(composite, weights.copy(), t.copy(), colours.copy()), "composite(weights, t, colours)")
        rgb = _as_array(out[0], (r, 3), "composite(...)[0] (rgb)")
        depth = _as_array(out[1], (r,), "composite(...)[1] (depth)")
        want_rgb, want_depth = _composite_reference(weights, t, colours)
        if _close(rgb, want_rgb) and _close(depth, want_depth):
            continue
        i = int(np.argmax(np.abs(rgb - want_rgb).sum(axis=1) + np.abs(depth - want_depth)))
        raise AssertionError(
            f"composite is wrong for ray {i} (accumulated weight {weights[i].sum():.3f}): "
            f"rgb {np.round(rgb[i], 4)}, depth {depth[i]:.4f}; expected rgb {np.round(want_rgb[i], 4)}, depth {want_depth[i]:.4f}\n"
            f"Hint: {_composite_hint(weights, t, colours, rgb, depth)}"
        )
    print(f"check_composite: {n_trials} batches of rays agree (each with one ray that hits nothing)")
    return True


# --------------------------------------------------------------------------------------------------
# Exercise 3: the loss of a batch (Eqs. 6-9) and one training step
# --------------------------------------------------------------------------------------------------
def _loss_parts(rendered, measured, log_clamp: float) -> dict[str, np.ndarray]:
    """Per-ray terms, in float64: squared colour error summed over channels, absolute depth error, clamped
    negative log-probability of the measured class."""
    rgb, depth, sem = (np.asarray(rendered[k].detach(), dtype=np.float64) for k in ("rgb", "depth", "sem"))
    m_rgb, m_depth = (np.asarray(measured[k], dtype=np.float64) for k in ("rgb", "depth"))
    labels = np.asarray(measured["labels"])
    picked = sem[np.arange(len(labels)), labels]
    with np.errstate(divide="ignore"):
        sem_raw = -np.log(picked)
    return {"rgb": ((rgb - m_rgb) ** 2).sum(axis=1), "depth": np.abs(depth - m_depth),
            "sem": -np.log(np.clip(picked, log_clamp, 1.0)), "rgb_elements": (rgb - m_rgb) ** 2,
            "depth_sq": (depth - m_depth) ** 2, "rgb_norm": np.sqrt(((rgb - m_rgb) ** 2).sum(axis=1)),
            "hit": m_depth > 0, "sem_raw": sem_raw}


def _loss_variants(rendered, measured, lambdas, log_clamp: float) -> dict[str, float]:
    """The right total and what common mistakes give instead."""
    p = _loss_parts(rendered, measured, log_clamp)
    l1, l2, l3 = lambdas
    right = l1 * p["rgb"].mean() + l2 * p["depth"].mean() + l3 * p["sem"].mean()
    return {
        "right": right,
        "channel_mean": l1 * p["rgb_elements"].mean() + l2 * p["depth"].mean() + l3 * p["sem"].mean(),
        "rgb_norm": l1 * p["rgb_norm"].mean() + l2 * p["depth"].mean() + l3 * p["sem"].mean(),
        "depth_squared": l1 * p["rgb"].mean() + l2 * p["depth_sq"].mean() + l3 * p["sem"].mean(),
        "hit_only": l1 * p["rgb"].mean() + l2 * p["depth"][p["hit"]].mean() + l3 * p["sem"].mean(),
        "sum": l1 * p["rgb"].sum() + l2 * p["depth"].sum() + l3 * p["sem"].sum(),
        "no_clamp": l1 * p["rgb"].mean() + l2 * p["depth"].mean() + l3 * p["sem_raw"].mean(),
        "lambdas_order": l3 * p["rgb"].mean() + l2 * p["depth"].mean() + l1 * p["sem"].mean(),
    }


_LOSS_HINTS = {
    "no_clamp": ("a rendered probability of exactly 0 for the measured class gives log(0) = -inf: clamp the probability "
                 "to at least log_clamp before the log, as Eq. 8's implementation does"),
    "channel_mean": "the colour term sums the squared error over the 3 channels of a ray, then averages over the rays",
    "rgb_norm": ("the colour term is the SQUARED error ||C - C_hat||^2 per ray (the paper writes the L2 norm; the "
                 "implementation squares it, as the reference code does)"),
    "depth_squared": "the depth term is the ABSOLUTE error |D - D_hat| (Eq. 7, an L1 loss), not its square",
    "hit_only": ("rays that hit nothing (measured depth 0) count too: they teach free space, since any weight along "
                 "them raises the rendered depth above 0"),
    "sum": "each term is a MEAN over the batch's rays, so that the loss does not grow with the batch size",
    "lambdas_order": "lambdas = (lambda_1, lambda_2, lambda_3) weigh (L_rgb, L_depth, L_sem) in that order (Eq. 9)",
}


def _loss_reference(rendered, measured, lambdas, log_clamp: float):
    """The same total in torch (it is what the cells after the exercise train with when the answer does not pass)."""
    l_rgb = ((rendered["rgb"] - measured["rgb"]) ** 2).sum(dim=1).mean()
    l_depth = (rendered["depth"] - measured["depth"]).abs().mean()
    picked = rendered["sem"].gather(1, measured["labels"][:, None]).squeeze(1)
    l_sem = -torch.log(picked.clamp(min=log_clamp, max=1.0)).mean()
    return lambdas[0] * l_rgb + lambdas[1] * l_depth + lambdas[2] * l_sem


def _random_batch(rng: np.random.Generator, rays: int, classes: int):
    """A rendered and a measured batch as torch tensors; the rendered ones require gradients. Ray 0 hits nothing
    (depth 0, white), and ray 1 renders probability exactly 0 for its measured class."""
    sem = rng.dirichlet(np.full(classes, 0.7), size=rays)
    labels = rng.integers(0, classes, size=rays)
    sem[1, labels[1]] = 0.0
    sem[1] /= sem[1].sum()
    m_depth = rng.uniform(0.5, 3.5, size=rays)
    m_depth[0] = 0.0
    m_rgb = rng.uniform(0.0, 1.0, size=(rays, 3))
    m_rgb[0] = 1.0
    rendered = {"rgb": rng.uniform(0.0, 1.0, size=(rays, 3)), "depth": rng.uniform(0.0, 3.5, size=rays), "sem": sem}
    rendered = {k: torch.tensor(v, dtype=torch.float64, requires_grad=True) for k, v in rendered.items()}
    measured = {"rgb": torch.tensor(m_rgb), "depth": torch.tensor(m_depth), "labels": torch.tensor(labels)}
    return rendered, measured


@compares_with(_loss_reference)
def check_batch_loss(batch_loss, n_trials: int = 20, seed: int = 0) -> bool:
    """``batch_loss(rendered, measured, lambdas, log_clamp)`` takes the rendered rays (a dict of torch tensors:
    ``rgb`` (R, 3), ``depth`` (R,), ``sem`` (R, P) class probabilities), the measured ones (``rgb``, ``depth``,
    ``labels`` (R,) class indices) and the weights ``(lambda_1, lambda_2, lambda_3)``, and returns Eq. 9 as a
    torch scalar that gradients flow through: lambda_1 L_rgb + lambda_2 L_depth + lambda_3 L_sem, each a mean
    over the rays of the squared colour error (summed over channels), the absolute depth error and
    -log(max(S_hat[label], log_clamp))."""
    rng = np.random.default_rng(seed)
    log_clamp = 1e-6
    answers, cases = [], []
    for _ in range(n_trials):
        rendered, measured = _random_batch(rng, int(rng.integers(4, 40)), int(rng.integers(2, 8)))
        lambdas = tuple(float(x) for x in rng.permutation([rng.uniform(0.5, 2.0), rng.uniform(0.05, 0.3), rng.uniform(2.0, 4.0)]))
        got = _call(batch_loss, rendered, {k: v.clone() for k, v in measured.items()}, lambdas, log_clamp)
        if got is None:
            raise AssertionError("batch_loss returned None: fill in the function body (it still looks like the stub)")
        if not isinstance(got, torch.Tensor) or got.numel() != 1:
            raise AssertionError(f"batch_loss must return a torch scalar (one number that .backward() can be called on), "
                                 f"got {type(got).__name__}")
        if got.grad_fn is None:
            raise AssertionError("batch_loss returned a tensor that gradients do not flow through: compute it with "
                                 "torch operations on the rendered tensors (no .detach(), .numpy() or float())")
        answers.append(float(got.detach()))
        cases.append(_loss_variants(rendered, measured, lambdas, log_clamp))
    same = [bool(np.isclose(a, c["right"], rtol=1e-6, atol=1e-9)) for a, c in zip(answers, cases)]
    if not all(same):
        i = same.index(False)
        rounded = [round(a, 6) if np.isfinite(a) else a for a in answers]
        variants = {name: [round(c[name], 6) if np.isfinite(c[name]) else c[name] for c in cases] for name in cases[0]}
        if not np.isfinite(answers[i]):
            hint = _LOSS_HINTS["no_clamp"]
        else:
            hint = diagnose(rounded, variants, _LOSS_HINTS,
                            "compare with Eqs. 6-9 loss by loss on a batch of one ray: each loss's value, then their weights")
        raise AssertionError(f"batch_loss returned {answers[i]:.6f}, expected {cases[i]['right']:.6f} (batch {i})\n"
                             f"Hint: {hint}")
    print(f"check_batch_loss: {n_trials} random batches agree (each with a ray that hits nothing and a zero probability)")
    return True


def _step_reference(model, optimizer, render, loss_fn, batch) -> float:
    rendered = render(model, batch)
    loss = loss_fn(rendered, batch)
    optimizer.zero_grad()
    loss.backward()
    optimizer.step()
    return loss.item()


def _tiny_problem(seed: int):
    """A small differentiable 'renderer' (a linear layer from ray features to rgb, depth and class logits), a
    batch, an Adam optimiser and the loss: three steps of it show every ordering mistake."""
    torch.manual_seed(seed)
    model = torch.nn.Linear(6, 3 + 1 + 4).double()
    optimizer = torch.optim.Adam(model.parameters(), lr=0.05)
    g = torch.Generator().manual_seed(seed)
    batch = {"features": torch.rand(16, 6, generator=g, dtype=torch.float64),
             "rgb": torch.rand(16, 3, generator=g, dtype=torch.float64),
             "depth": torch.rand(16, generator=g, dtype=torch.float64) * 3,
             "labels": torch.randint(0, 4, (16,), generator=g)}

    def render(m, b):
        out = m(b["features"])
        return {"rgb": torch.sigmoid(out[:, :3]), "depth": out[:, 3], "sem": torch.softmax(out[:, 4:], dim=1)}

    def loss_fn(rendered, b):
        return _loss_reference(rendered, b, (1.0, 0.1, 1.0), 1e-6)

    return model, optimizer, render, loss_fn, batch


@compares_with(_step_reference)
def check_training_step(training_step, n_steps: int = 3, seed: int = 0) -> bool:
    """``training_step(model, optimizer, render, loss_fn, batch)`` renders the batch (``render(model, batch)``),
    computes ``loss_fn(rendered, batch)``, makes one optimiser step on it and returns the loss as a Python float.
    Checked on a small model over ``n_steps`` consecutive steps against the reference order of operations."""
    mine, ref = _tiny_problem(seed), _tiny_problem(seed)
    for step in range(1, n_steps + 1):
        before = [p.detach().clone() for p in mine[0].parameters()]
        got = _call(training_step, *mine)
        want = _step_reference(*ref)
        if got is None:
            raise AssertionError("training_step returned None: return the batch's loss as a float (loss.item())")
        if isinstance(got, torch.Tensor):
            raise AssertionError("training_step must return a Python float (loss.item()): a tensor keeps the whole "
                                 "rendering graph alive until it is freed")
        if not np.isclose(float(got), want, rtol=1e-9):
            raise AssertionError(f"step {step}: training_step returned the loss {float(got):.6f}, expected {want:.6f}\n"
                                 "Hint: return the loss of the batch computed BEFORE the optimiser step")
        params, params_ref = list(mine[0].parameters()), list(ref[0].parameters())
        if all(torch.equal(b, p) for b, p in zip(before, params)):
            raise AssertionError(f"step {step}: the parameters did not change\nHint: after loss.backward() call "
                                 "optimizer.step(); and zero the gradients BEFORE backward(), not between backward() and step()")
        if not all(torch.allclose(p, q, rtol=1e-9, atol=1e-12) for p, q in zip(params, params_ref)):
            hint = ("gradients ADD UP in .grad across backward() calls: call optimizer.zero_grad() before "
                    "loss.backward() in every step" if step > 1 else
                    "the order is: render, loss, optimizer.zero_grad(), loss.backward(), optimizer.step()")
            raise AssertionError(f"after step {step} the parameters differ from the reference step's\nHint: {hint}")
    print(f"check_training_step: {n_steps} consecutive steps give the reference parameters and losses")
    return True


# --------------------------------------------------------------------------------------------------
# Trilinear interpolation (section 1, Eq. 1)
# --------------------------------------------------------------------------------------------------
def _weighted_corners(V, lower, f):
    """Sum over the 8 corners of each point's cell (lower corner ``lower`` (N, 3)) of the corner's value times the product
    over the axes of f (upper corner) or 1 - f (lower corner)."""
    out = np.zeros((len(lower), V.shape[-1]))
    for corner in np.ndindex(2, 2, 2):
        c = np.array(corner)
        weight = np.prod(np.where(c == 1, f, 1.0 - f), axis=1)
        out += weight[:, None] * V[lower[:, 0] + c[0], lower[:, 1] + c[1], lower[:, 2] + c[2]]
    return out


def _cell_and_fraction(p, r):
    """The lower corner of the cell of continuous vertex coordinates p (the last cell on the upper face) and the
    fractional position in it."""
    lower = np.clip(np.floor(p), 0, r - 2).astype(int)
    return lower, np.clip(p - lower, 0.0, 1.0)


def _trilinear_reference(V, x, bound=1.0):
    r = V.shape[0]
    return _weighted_corners(V, *_cell_and_fraction((np.asarray(x, np.float64) + bound) / (2 * bound) * (r - 1), r))


def _trilinear_variants(V, x, bound) -> dict[str, np.ndarray]:
    """The right values and what common mistakes give instead."""
    r = V.shape[0]
    nearest = np.clip(np.round((x + bound) / (2 * bound) * (r - 1)), 0, r - 1).astype(int)
    lower, f = _cell_and_fraction((x + bound) / (2 * bound) * (r - 1), r)
    return {"right": _trilinear_reference(V, x, bound), "nearest": V[nearest[:, 0], nearest[:, 1], nearest[:, 2]],
            "cell_centres": _weighted_corners(V, *_cell_and_fraction((x + bound) / (2 * bound) * r - 0.5, r)),
            "weights_swapped": _weighted_corners(V, lower, 1.0 - f),
            "axes_reversed": _trilinear_reference(V.transpose(2, 1, 0, 3), x, bound)}


_TRILINEAR_HINTS = {
    "nearest": "you returned the nearest vertex's value: interpolate between the 8 vertices of the point's cell",
    "cell_centres": ("the vertices sit ON the cube's corners here (align_corners=True): vertex i is at -b + i 2b / (R - 1), "
                     "so the continuous vertex coordinate is (x + b) / (2b) (R - 1), not (x + b) / (2b) R - 0.5"),
    "weights_swapped": ("the weights are swapped: the corner at the upper end of an axis gets the fraction f, the lower "
                        "one 1 - f (at f = 0 the point sits on the lower vertex)"),
    "axes_reversed": "V is indexed [i, j, k] = (x, y, z): the first index goes with the point's x coordinate",
}


@compares_with(_trilinear_reference)
def check_trilinear(trilinear, n_trials: int = 8, seed: int = 0) -> bool:
    """``trilinear(V, x, bound)``: V (R, R, R, C) vertex features indexed [i, j, k] = (x, y, z) on a lattice whose corner
    vertices sit on the corners of the cube [-bound, bound]^3; x (N, 3) points in the cube; returns (N, C)."""
    rng = np.random.default_rng(seed)
    for trial in range(n_trials):
        r, c, bound = int(rng.integers(3, 7)), int(rng.integers(1, 4)), float(rng.choice([1.0, 1.5, 0.5]))
        V = rng.normal(size=(r, r, r, c))
        x = rng.uniform(-bound, bound, size=(200, 3))
        x[:8] = bound * np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T  # the cube's corners
        for axis in range(3):  # points on each upper face: they belong to the last cell along that axis
            x[8 + 4 * axis : 12 + 4 * axis, axis] = bound
        got = _as_array(_call(trilinear, V.copy(), x.copy(), bound), (len(x), c), "trilinear(V, x, bound)")
        variants = _trilinear_variants(V, x, bound)
        if _close(got, variants["right"]):
            continue
        hint = next((h for name, h in _TRILINEAR_HINTS.items() if _close(got, variants[name])),
                    "check a point at a vertex (it must return that vertex's value) and one halfway along a cell edge (the mean of "
                    "the edge's two vertices), then Eq. 1's weights in 3-D")
        bad = int(np.argmax(np.abs(got - variants["right"]).max(axis=1)))
        raise AssertionError(f"trilinear is wrong on a {r}^3 grid with bound {bound}: at x = {np.round(x[bad], 4)} you "
                             f"returned {np.round(got[bad], 4)}, expected {np.round(variants['right'][bad], 4)}\n"
                             f"Hint: {hint}")
    print(f"check_trilinear: {n_trials} random grids (corners and upper faces included) agree")
    return True
