"""The semantic implicit map (paper Sec. III-A): three dense feature grids read by trilinear
interpolation (Eq. 1), a positional encoding gamma, and heads for occupancy, colour and semantics.

Introduced in notebook 02 (occupancy and colour) and notebook 03 (semantics).
Grid layout: the grids are stored channels-last as tables of shape (R^3, C) over the field's
``Lattice`` (lattice.py): row (k R + j) R + i holds the features of vertex (x_i, y_j, z_k), and vertex i
is at x = -bound + i * 2 bound / (R - 1), the convention of ``F.grid_sample(..., align_corners=True)``.
Two tables: ``grid_occ`` holds V_occ, read at every sample; ``grid_app`` holds V_rgb and V_sem side by
side, read only where colour and classes can matter. A hand-written trilinear lookup (forward: one
weighted ``embedding_bag``; backward: a scatter-add into the touched rows) gives the numbers of
``grid_sample`` (notebook 02 checks) several times faster on a CPU.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from .config import FieldConfig, TrainConfig
from .lattice import Lattice, flat_index


def positional_encoding(x: torch.Tensor, n_frequencies: int) -> torch.Tensor:
    """gamma(x) = [x, sin(2^k x), cos(2^k x)] for k < n_frequencies, on coordinates in [-1, 1].

    With 3 frequencies this maps R^3 to R^21, as in the paper. (The reference code drops the raw x.)
    """
    scaled = x[..., None, :] * (2.0 ** torch.arange(n_frequencies, dtype=x.dtype, device=x.device))[:, None]
    scaled = scaled.flatten(-2)
    return torch.cat([x, torch.sin(scaled), torch.cos(scaled)], dim=-1)


def class_probabilities(logits: torch.Tensor) -> torch.Tensor:
    """s(x) = softmax of the semantic logits (N, P) over the P classes: the per-sample class probabilities s_i of Eq. 4.
    Computed along the leading axis of the transposed (P, N) logits: on a CPU, torch's softmax along a last axis of 7
    entries runs about 6x slower than along a leading one (one thread; it was 15 % of a lite training update's CPU
    time), for the same values to rounding."""
    return torch.softmax(logits.t(), dim=0).t()


def corner_indices_and_weights(x_normalised: torch.Tensor, resolution: int) -> tuple[torch.Tensor, torch.Tensor]:
    """The 8 surrounding vertices (row indices into the (R^3, C) table) and trilinear weights of points in [-1, 1]^3."""
    r = resolution
    p = (x_normalised.clamp(-1.0, 1.0) + 1.0) * 0.5 * (r - 1)
    i0 = p.floor().clamp(0, r - 2)
    f = p - i0
    i0 = i0.long()
    base = flat_index(i0[:, 0], i0[:, 1], i0[:, 2], r)
    offsets = torch.tensor([0, 1, r, r + 1, r * r, r * r + 1, r * r + r, r * r + r + 1], device=x_normalised.device)
    fx, fy, fz = f[:, 0:1], f[:, 1:2], f[:, 2:3]
    gx, gy, gz = 1 - fx, 1 - fy, 1 - fz
    weights = torch.cat([gx * gy * gz, fx * gy * gz, gx * fy * gz, fx * fy * gz, gx * gy * fz, fx * gy * fz, gx * fy * fz, fx * fy * fz], 1)
    return base[:, None] + offsets, weights


class _TrilinearLookup(torch.autograd.Function):
    """sum_k w_k V[idx_k]; the backward pass scatter-adds w_k * grad into the 8 touched rows: of a new zero table,
    or, with ``into_grad``, of the table's existing ``.grad`` (in training: no full-size zero table per pass, which
    at 128^3 costs more than the scatter itself)."""

    @staticmethod
    def forward(ctx, table, index, weights, into_grad=False):
        ctx.save_for_backward(index, weights)
        ctx.table, ctx.into_grad = table, into_grad
        # a weighted sum of 8 table rows per point: exactly what a weighted embedding bag computes
        return F.embedding_bag(index, table, per_sample_weights=weights, mode="sum")

    @staticmethod
    def backward(ctx, grad_out):
        index, weights = ctx.saved_tensors
        contributions = (weights[:, :, None] * grad_out[:, None, :]).reshape(-1, grad_out.shape[1])
        existing = ctx.table.grad if ctx.into_grad else None
        if existing is not None:
            existing.index_add_(0, index.reshape(-1), contributions)
            return None, None, None, None
        grad_table = torch.zeros(ctx.table.shape[0], grad_out.shape[1], dtype=grad_out.dtype, device=grad_out.device)
        grad_table.index_add_(0, index.reshape(-1), contributions)
        return grad_table, None, None, None


def trilinear(table: torch.Tensor, resolution: int, x_normalised: torch.Tensor) -> torch.Tensor:
    """interp(x, V) of Eq. 1: features (N, C) of a grid stored as a (R^3, C) table, at points (N, 3) in [-1, 1]^3."""
    index, weights = corner_indices_and_weights(x_normalised, resolution)
    return _TrilinearLookup.apply(table, index, weights)


@dataclass
class Located:
    """Points located in the field's lattice: their 8 corner rows and trilinear weights, and gamma(x).
    Computed once per sample; every table is then read at the same corners. gamma(x) is computed when first
    read (``pe``): a render that drops samples first (another class's, whose occupancy it zeroes) encodes only
    the rest."""

    index: torch.Tensor  # (N, 8) rows of the (R^3, C) tables
    weights: torch.Tensor  # (N, 8) trilinear weights
    normalised: torch.Tensor  # (N, 3) the points in [-1, 1]^3
    pe_frequencies: int
    grad_into_existing: bool = False  # backward adds the tables' gradients into their .grad (SemanticField)

    @functools.cached_property
    def pe(self) -> torch.Tensor:
        """gamma(x), (N, 21) for 3 frequencies."""
        return positional_encoding(self.normalised, self.pe_frequencies)

    def share_of(self, vertices: torch.Tensor) -> torch.Tensor:
        """The trilinear share (N,) of the points' corners that are set in a boolean vertex mask (R^3,)."""
        return (self.weights * vertices.index_select(0, self.index.view(-1)).view(self.index.shape)).sum(dim=1)

    def subset(self, rows: torch.Tensor) -> "Located":
        """The same for the points selected by ``rows`` (a boolean mask or indices); gamma(x) is taken along when
        it was computed already. Rows are gathered with ``index_select`` (on a CPU about twice as fast as indexing)."""
        rows = rows.nonzero().squeeze(1) if rows.dtype == torch.bool else rows
        located = Located(*(x.index_select(0, rows) for x in (self.index, self.weights, self.normalised)),
                          self.pe_frequencies, self.grad_into_existing)
        if "pe" in self.__dict__:
            located.pe = self.pe.index_select(0, rows)
        return located

    def read(self, table: torch.Tensor) -> torch.Tensor:
        """interp(x, V) of Eq. 1 for a (R^3, C) table: (N, C)."""
        return _TrilinearLookup.apply(table, self.index, self.weights, self.grad_into_existing)


def first_layer_on_parts(first: nn.Linear, parts, in_place: bool = False) -> torch.Tensor:
    """``first(torch.cat(parts, dim=1))`` without building the concatenated input: the layer is applied to each part
    with its slice of the weights, and the products summed (the same sum in another order; a concatenation of narrow
    columns is a row-by-row copy on a CPU, as costly as the layer itself). ``in_place``: each later product is added
    inside its matrix product (``addmm_``, no gradients; no separate pass over the sum)."""
    start, out = 0, None
    for part in parts:
        weight = first.weight[:, start : start + part.shape[1]]
        if out is None:
            out = F.linear(part, weight, first.bias)
        else:
            out = out.addmm_(part, weight.t()) if in_place else out + F.linear(part, weight)
        start += part.shape[1]
    return out


def mlp_on_parts(net: nn.Sequential, *parts: torch.Tensor) -> torch.Tensor:
    """``net(torch.cat(parts, dim=1))``, its first layer applied part by part (``first_layer_on_parts``)."""
    return net[1:](first_layer_on_parts(net[0], parts))


@torch.no_grad()
def mlp_on_parts_in_blocks(net: nn.Sequential, *parts: torch.Tensor, rows: int = 4096) -> torch.Tensor:
    """``mlp_on_parts`` for inference, ``rows`` rows at a time with each ReLU applied in place: a block's hidden
    activations (4096 x 128 floats, 2 MB) stay in the CPU's caches, where a whole batch's (about 1e5 x 128 floats a
    layer in a paper-scale evaluation render) would pass through memory once per layer and again per ReLU. The same
    rows as ``mlp_on_parts`` (tested); for a ``mlp`` (linear layers with a ReLU between each two)."""
    linears = list(net[::2])
    if not all(isinstance(layer, nn.Linear) for layer in linears) or not all(isinstance(a, nn.ReLU) for a in net[1::2]):
        raise ValueError(f"mlp_on_parts_in_blocks takes a mlp() of linear layers with a ReLU between them, got {net}")
    out = torch.empty(len(parts[0]), linears[-1].out_features, dtype=parts[0].dtype, device=parts[0].device)
    for start in range(0, len(out), rows):
        hidden = first_layer_on_parts(linears[0], [part[start : start + rows] for part in parts], in_place=True)
        for layer in linears[1:]:
            hidden = F.linear(hidden.relu_(), layer.weight, layer.bias)
        out[start : start + rows] = hidden
    return out


def mlp(n_in: int, hidden: tuple[int, ...], n_out: int) -> nn.Sequential:
    """A ReLU MLP with the given hidden widths."""
    layers, width = [], n_in
    for h in hidden:
        layers += [nn.Linear(width, h), nn.ReLU()]
        width = h
    layers.append(nn.Linear(width, n_out))
    return nn.Sequential(*layers)


class SemanticField(nn.Module):
    """Occupancy o(x) in [0, 1], colour c(x) in [0, 1]^3 and semantic probabilities s(x) over the classes.

    V_occ is the table ``grid_occ``; V_rgb and V_sem are channel slices of ``grid_app``, so one trilinear
    lookup serves both, and only where colour and classes are needed. The semantic head is the identity
    (softmax of the interpolated V_sem, no positional encoding), as the paper states; colour has no view
    dependence. With ``cfg.reached_only`` the occupancy is zero in the cells no measured ray reached (``reached``,
    which the trainer marks; README, "No phantom").
    """

    def __init__(self, cfg: FieldConfig, seed: int = 0):
        super().__init__()
        self.cfg = cfg
        self.lattice = Lattice(cfg.grid_resolution, cfg.bound)  # the field owns its world-to-grid mapping
        r = cfg.grid_resolution
        self.grid_occ = nn.Parameter(torch.zeros(r**3, cfg.occ_channels))
        self.grid_app = nn.Parameter(torch.zeros(r**3, cfg.rgb_channels + cfg.sem_channels))
        pe_dim = 3 * (1 + 2 * cfg.pe_frequencies)
        generator_state = torch.random.get_rng_state()
        torch.manual_seed(seed)  # MLP initialisation is seeded, and the global state is restored after
        self.occ_mlp = mlp(cfg.occ_channels + (pe_dim - 3 if cfg.occ_reads_position else 0), cfg.occ_hidden, 1)
        if not cfg.occ_hidden:  # the reference code's linear head: every weight 0.1, bias 0, so the map starts empty
            nn.init.constant_(self.occ_mlp[0].weight, 0.1)
            nn.init.zeros_(self.occ_mlp[0].bias)
        self.rgb_mlp = mlp(cfg.rgb_channels + pe_dim, cfg.rgb_hidden, 3)
        torch.random.set_rng_state(generator_state)
        # the vertices whose cells a measured ray reached (Trainer.add_measurement marks them); with cfg.reached_only,
        # occupancy is zero where none of a cell's corners is marked: a new field is empty everywhere. Derived from the
        # measurements, which a resumed mission adds again, so checkpoints do not store it
        self.register_buffer("reached", torch.zeros(r**3, dtype=torch.bool), persistent=False)
        # how often the measurements saw a surface at each vertex (the nearest vertex of a back-projected depth point):
        # in how many views, and by how many rays. Read by the coverage and Fisher utilities (utility.py); derived from
        # the measurements like ``reached``
        self.register_buffer("surface_views", torch.zeros(r**3), persistent=False)
        self.register_buffer("surface_rays", torch.zeros(r**3), persistent=False)
        # True while training.accumulate_gradient runs: the grids' gradients are added into their existing .grad
        # (the sum autograd would form) instead of into a new full-size zero table per pass
        self.grid_grad_into_existing = False

    @staticmethod
    def _grid_view(table: torch.Tensor, start: int, stop: int, r: int) -> torch.Tensor:
        return table[:, start:stop].t().reshape(stop - start, r, r, r)

    @property
    def V_occ(self) -> torch.Tensor:
        """The occupancy feature grid, (T_occ, R, R, R) indexed [channel, z, y, x]."""
        return self._grid_view(self.grid_occ, 0, self.cfg.occ_channels, self.cfg.grid_resolution)

    @property
    def V_rgb(self) -> torch.Tensor:
        """The colour feature grid, (T_rgb, R, R, R)."""
        return self._grid_view(self.grid_app, 0, self.cfg.rgb_channels, self.cfg.grid_resolution)

    @property
    def V_sem(self) -> torch.Tensor:
        """The semantic grid, (T_sem, R, R, R): per-vertex class logits."""
        c = self.cfg
        return self._grid_view(self.grid_app, c.rgb_channels, c.rgb_channels + c.sem_channels, c.grid_resolution)

    @property
    def device(self) -> torch.device:
        return self.grid_occ.device

    def param_groups(self, cfg: TrainConfig) -> list[dict]:
        """The optimiser's parameter groups: the grids at ``lr_grid``, the colour MLP at ``lr_mlp``, the occupancy
        head at ``lr_occupancy_head`` (``lr_mlp`` when None)."""
        occ_lr = cfg.lr_mlp if cfg.lr_occupancy_head is None else cfg.lr_occupancy_head
        return [{"params": [self.grid_occ, self.grid_app], "lr": cfg.lr_grid},
                {"params": list(self.rgb_mlp.parameters()), "lr": cfg.lr_mlp},
                {"params": list(self.occ_mlp.parameters()), "lr": occ_lr}]

    def locate(self, x: torch.Tensor) -> Located:
        """Corner rows and trilinear weights of world points x (N, 3), and gamma(x) when first read."""
        xn = self.lattice.normalise(x)
        index, weights = corner_indices_and_weights(xn, self.cfg.grid_resolution)
        return Located(index, weights, xn, self.cfg.pe_frequencies, self.grid_grad_into_existing)

    def head_occupancy_at(self, located: Located) -> torch.Tensor:
        """The occupancy head's o at located points (N,): V_occ read there, then the head, wherever a ray reached or not."""
        return self.occupancy_from(located.read(self.grid_occ), located.pe)

    def occupancy_at(self, located: Located) -> torch.Tensor:
        """o at located points (N,): the head's (``head_occupancy_at``); with ``cfg.reached_only`` times the share of
        the points' cell corners a measured ray reached (zero in a cell no ray reached)."""
        o = self.head_occupancy_at(located)
        return o * located.share_of(self.reached) if self.cfg.reached_only else o

    def appearance_at(self, located: Located) -> tuple[torch.Tensor, torch.Tensor]:
        """(f_rgb, f_sem) at located points: V_rgb and V_sem read there in one lookup."""
        return torch.split(located.read(self.grid_app), (self.cfg.rgb_channels, self.cfg.sem_channels), dim=1)

    def features(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """(f_occ, f_rgb, f_sem, gamma(x)) at world points x (N, 3)."""
        located = self.locate(x)
        f_rgb, f_sem = self.appearance_at(located)
        return located.read(self.grid_occ), f_rgb, f_sem, located.pe

    def occupancy_from(self, f_occ: torch.Tensor, pe: torch.Tensor) -> torch.Tensor:
        """o = 1 - exp(-softplus(MLP_occ(f_occ, gamma) + shift)), a probability in [0, 1).

        The head reads gamma without the raw x (``pe[:, 3:]``, the sin/cos terms), as the reference code: a head
        that reads x extrapolates occupancy into volume no ray has reached (README, "No phantom"). With
        ``occ_reads_position`` off it reads f_occ alone."""
        parts = (f_occ, pe[:, 3:]) if self.cfg.occ_reads_position else (f_occ,)
        logit = mlp_on_parts(self.occ_mlp, *parts).squeeze(1) + self.cfg.occupancy_shift
        return -torch.expm1(-F.softplus(logit))

    def colour_from(self, f_rgb: torch.Tensor, pe: torch.Tensor) -> torch.Tensor:
        """c = sigmoid(MLP_rgb(f_rgb, gamma)) in [0, 1]^3 (without gradients, in cache-sized blocks:
        ``mlp_on_parts_in_blocks``)."""
        if torch.is_grad_enabled():
            return torch.sigmoid(mlp_on_parts(self.rgb_mlp, f_rgb, pe))
        return mlp_on_parts_in_blocks(self.rgb_mlp, f_rgb, pe).sigmoid_()

    def forward(self, x: torch.Tensor) -> dict[str, torch.Tensor]:
        """Occupancy (N,), colour (N, 3) and semantic logits (N, P) at world points x (N, 3)."""
        located = self.locate(x)
        f_rgb, f_sem = self.appearance_at(located)
        return {"occ": self.occupancy_at(located), "rgb": self.colour_from(f_rgb, located.pe), "sem_logits": f_sem}

    @torch.no_grad()
    def query(self, x: torch.Tensor, chunk: int = 262144) -> dict[str, torch.Tensor]:
        """Occupancy and semantic probabilities at many points, in chunks written into the outputs, without
        gradients."""
        occ = torch.empty(len(x), device=x.device)
        sem = torch.empty(len(x), self.cfg.sem_channels, device=x.device)
        for start in range(0, len(x), chunk):
            located = self.locate(x[start : start + chunk])
            occ[start : start + chunk] = self.occupancy_at(located)
            sem[start : start + chunk] = class_probabilities(self.appearance_at(located)[1])
        return {"occ": occ, "sem": sem}
