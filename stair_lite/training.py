"""Incremental training of the semantic field (paper Sec. III-B, Eq. 6-9).

Introduced in notebook 02 (one fit) and notebook 03 (incremental, with replay).
After each new measurement the field trains a fixed number of iterations; each batch is half rays
of the newest measurement and half rays replayed from all earlier ones, a ray's chance of being
replayed inversely proportional to how often it has been used (paper Sec. III-B).
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np
import torch

from .config import RenderConfig, TrainConfig
from .geometry import pixel_rays
from .measurement import Measurement, back_project, measured_rays
from .rendering import SkipGrid, build_skip_grid, reached_vertices, render_rays

LOG_CLAMP = 1e-6  # probabilities are clamped before log(): cross entropy stays finite


class RayBuffer:
    """Every ray measured so far, stored once: origin, direction, rgb, depth (one float32 row of 10) and
    label, with per-ray use counts. 45 bytes per ray (``BYTES_PER_RAY``): 7.2 MB per 400x400 view.

    Rows live in arrays whose capacity doubles when full, so appending a view costs amortised constant
    time per ray (no earlier ray is copied again), and a view's rays are the contiguous rows from its
    start offset on.
    """

    FLOATS = ("origins", 3), ("dirs", 3), ("rgb", 3), ("depth", 1)  # the float32 columns, in row order
    BYTES_PER_RAY = 10 * 4 + 1 + 4  # floats, uint8 label, int32 use count

    def __init__(self):
        self._floats = np.zeros((0, 10), dtype=np.float32)
        self._labels = np.zeros(0, dtype=np.uint8)
        self._counts = np.zeros(0, dtype=np.int32)
        self._size = 0
        self.view_starts: list[int] = []  # buffer index of each view's first ray

    def __len__(self) -> int:
        return self._size

    @property
    def n_views(self) -> int:
        return len(self.view_starts)

    @property
    def nbytes(self) -> int:
        """Bytes held by the buffer's arrays (capacity included)."""
        return self._floats.nbytes + self._labels.nbytes + self._counts.nbytes

    @property
    def use_counts(self) -> np.ndarray:
        """How often each ray has been trained on (a view of the stored counts: writes go through)."""
        return self._counts[: self._size]

    @use_counts.setter
    def use_counts(self, counts: np.ndarray) -> None:
        if len(counts) != self._size:
            raise ValueError(f"{len(counts)} use counts for a buffer of {self._size} rays")
        self._counts[: self._size] = counts

    def _reserve(self, n: int) -> None:
        capacity = len(self._labels)
        if self._size + n <= capacity:
            return
        capacity = max(self._size + n, 2 * capacity)
        for name in ("_floats", "_labels", "_counts"):
            old = getattr(self, name)
            new = np.zeros((capacity,) + old.shape[1:], dtype=old.dtype)
            new[: self._size] = old[: self._size]
            setattr(self, name, new)

    def add(self, m: Measurement) -> None:
        """Append all rays of one measurement (checked by the Measurement record itself)."""
        origins, dirs = pixel_rays(m.intrinsics, m.pose)
        n = len(origins)
        self._reserve(n)
        rows = slice(self._size, self._size + n)
        self._floats[rows] = np.concatenate([origins, dirs, m.rgb.reshape(-1, 3), m.depth.reshape(-1, 1)], axis=1)
        self._labels[rows] = m.labels.reshape(-1)
        self._counts[rows] = 0
        self.view_starts.append(self._size)
        self._size += n

    def rays(self, index: np.ndarray) -> dict[str, np.ndarray]:
        """The rays at the given buffer indices (labels as int64, ready for indexing)."""
        floats, out, column = self._floats[index], {}, 0
        for name, width in self.FLOATS:
            out[name] = floats[:, column] if width == 1 else floats[:, column : column + width]
            column += width
        out["labels"] = self._labels[index].astype(np.int64)
        return out

    @property
    def view_index(self) -> np.ndarray:
        """The view number of every ray (0 for the first measurement), computed on demand."""
        lengths = np.diff(np.r_[self.view_starts, self._size]).astype(np.int64)
        return np.repeat(np.arange(self.n_views), lengths)

    def newest_indices(self) -> np.ndarray:
        return np.arange(self.view_starts[-1], self._size) if self.view_starts else np.zeros(0, dtype=np.int64)

    def replay_indices(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Draw ``n`` distinct rays of earlier views, P(ray) proportional to 1 / (1 + times used).

        Weighted sampling without replacement by the exponential-keys method: key = E / weight with
        E ~ Exp(1); the n smallest keys are a weighted sample (Efraimidis and Spirakis).
        """
        n_old = self.view_starts[-1] if self.view_starts else 0
        if n_old == 0 or n <= 0:
            return np.zeros(0, dtype=np.int64)
        keys = rng.exponential(size=n_old) * (1.0 + self._counts[:n_old])
        n = min(n, n_old)
        return np.argpartition(keys, n - 1)[:n]


@dataclass
class Losses:
    """The loss terms of one iteration (Eq. 9), as floats."""

    total: float
    rgb: float
    depth: float
    sem: float


def loss_terms(out: dict[str, torch.Tensor], batch: dict[str, torch.Tensor], cfg: TrainConfig):
    """lambda1 L_rgb + lambda2 L_depth + lambda3 L_sem (Eq. 6-9), each a mean over the batch's rays.

    L_rgb: squared colour error; L_depth: absolute depth error (background rays have depth 0, so
    they teach free space: any weight along them raises the rendered depth); L_sem: cross entropy of
    the rendered class probabilities, clamped away from log(0).
    """
    l_rgb = ((out["rgb"] - batch["rgb"]) ** 2).sum(dim=1).mean()
    l_depth = (out["depth"] - batch["depth"]).abs().mean()
    picked = out["sem"].gather(1, batch["labels"][:, None]).squeeze(1)
    l_sem = -torch.log(picked.clamp(min=LOG_CLAMP, max=1.0)).mean()
    total = cfg.lambda_rgb * l_rgb + cfg.lambda_depth * l_depth + cfg.lambda_sem * l_sem
    return total, l_rgb, l_depth, l_sem


def accumulate_gradient(field, batch: dict[str, torch.Tensor], cfg: TrainConfig, render_cfg: RenderConfig,
                        generator: torch.Generator | None = None, skip=None) -> torch.Tensor:
    """Add the gradient of the batch-mean loss (Eq. 9) to the field's parameters, rendering the batch in passes
    of at most ``cfg.rays_per_pass`` rays (each pass adds its share), and return the four loss terms (total,
    rgb, depth, semantic) as batch means."""
    n = len(batch["depth"])
    terms = torch.zeros(4)
    try:
        for start in range(0, n, cfg.rays_per_pass):
            field.grid_grad_into_existing = True  # add into the grids' .grad where one exists (no zero table per pass)
            part = {k: v[start : start + cfg.rays_per_pass] for k, v in batch.items()}
            out = render_rays(field, part["origins"], part["dirs"], render_cfg, generator=generator, depth=part["depth"], skip=skip)
            share = len(part["depth"]) / n
            part_terms = loss_terms(out, part, cfg)
            (part_terms[0] * share).backward()
            terms += torch.stack([t.detach().cpu() for t in part_terms]) * share
    finally:
        field.grid_grad_into_existing = False
    return terms


class GridAdam(torch.optim.Adam):
    """torch's fused Adam (betas 0.9, 0.99, the same floats), which on the field's feature grids visits only the rows a
    gradient may have reached.

    A grid row that no gradient has reached has zero moments, and Adam leaves it as it is (with g = m = v = 0 its
    step is lr * 0 / (0 + eps) = 0). In training, samples are evaluated only in the cells the skip grid keeps, so a
    row can receive a gradient only within one vertex of a kept vertex (its 8 cell corners); the trainer marks those
    rows ``mark_live`` whenever it builds a skip grid, or every row when it trains without one. The step and
    ``zero_grad`` then visit the grids' runs of whole x-lines (R rows) that hold a live row, as slices: at the paper's
    128^3 about 40 % of each grid, where the step over every row (33.5 M values) was a third of a training
    iteration's time. Whole lines, not single rows: every slice's length is then a multiple of 128 x C values, as the
    whole table's is (a gather of arbitrary rows into one compact table, whose length is not, was measured to give a
    few values other bits: the kernel's vector loop and its scalar remainder round differently). Rows outside are not read or written; a test checks the
    parameters, moments and losses against ``torch.optim.Adam(fused=True)`` bit for bit."""

    def __init__(self, field, cfg: TrainConfig):
        super().__init__(field.param_groups(cfg), betas=(0.9, 0.99), fused=True)
        self.grids = (field.grid_occ, field.grid_app)
        self.line = field.lattice.resolution  # rows per x-line of the tables
        self.live_rows = torch.zeros(field.grid_occ.shape[0], dtype=torch.bool, device=field.device)
        self._spans: list[tuple[int, int]] | None = []  # the live runs of lines, as row ranges (None: to recompute)
        if any(grid.shape[0] != len(self.live_rows) for grid in self.grids):
            raise ValueError(f"the grids have {[g.shape[0] for g in self.grids]} rows, not one row per lattice vertex")
        if any(self.grid_group[option] for option in ("amsgrad", "maximize", "weight_decay", "decoupled_weight_decay")):
            raise ValueError("GridAdam takes plain Adam: no amsgrad, maximize or weight decay")

    @property
    def grid_group(self) -> dict:
        """The parameter group of the grids (looked up each time: loading a state dict replaces the groups)."""
        return next(g for g in self.param_groups if any(p is self.grids[0] for p in g["params"]))

    def mark_live(self, rows: torch.Tensor | None = None) -> None:
        """Rows (a boolean mask over the lattice's vertices; None: all) that gradients may reach from now on."""
        self.live_rows |= True if rows is None else rows
        self._spans = None

    @property
    def spans(self) -> list[tuple[int, int]]:
        """Row ranges [start, stop) of the runs of consecutive x-lines that hold a live row."""
        if self._spans is None:
            lines = self.live_rows.view(-1, self.line).any(dim=1).cpu()
            padded = torch.cat([torch.zeros(1, dtype=torch.int8), lines.to(torch.int8), torch.zeros(1, dtype=torch.int8)])
            edges = (padded[1:] - padded[:-1]).nonzero().squeeze(1).tolist()  # run starts and stops, alternating
            self._spans = [(start * self.line, stop * self.line) for start, stop in zip(edges[::2], edges[1::2])]
        return self._spans

    def load_state_dict(self, state_dict: dict) -> None:
        """As torch's; the rows whose moments are not zero are live."""
        super().load_state_dict(state_dict)
        for grid in self.grids:
            for moment in ("exp_avg", "exp_avg_sq"):
                if moment in self.state[grid]:
                    self.mark_live((self.state[grid][moment] != 0).any(dim=1))

    @contextlib.contextmanager
    def _grids_left_out(self):
        """torch's own step and zero_grad leave out a parameter without a gradient: the grids' are set aside meanwhile
        (and given to the block)."""
        grads = [grid.grad for grid in self.grids]
        for grid in self.grids:
            grid.grad = None
        try:
            yield grads
        finally:
            for grid, grad in zip(self.grids, grads):
                grid.grad = grad

    def zero_grad(self, set_to_none: bool = True) -> None:
        """As torch's, but the grids' gradients are zeroed in place on the live spans only (nothing else was written)."""
        with self._grids_left_out() as grads:
            super().zero_grad(set_to_none)
        for grid, grad in zip(self.grids, grads):
            if grad is not None and set_to_none:
                grid.grad = None
            elif grad is not None:
                for start, stop in self.spans:
                    grad[start:stop].zero_()

    @torch.no_grad()
    def step(self) -> None:
        """torch's fused step on the other parameters; on the grids the same kernel over the live spans."""
        with self._grids_left_out():
            super().step()
        group = self.grid_group
        for grid in self.grids:
            if grid.grad is None:
                continue
            state = self.state[grid]
            if not state:  # as torch initialises a fused Adam's state
                state["step"] = torch.zeros((), dtype=torch.float32, device=grid.device)
                state["exp_avg"] = torch.zeros_like(grid, memory_format=torch.preserve_format)
                state["exp_avg_sq"] = torch.zeros_like(grid, memory_format=torch.preserve_format)
            state["step"] += 1
            spans = self.spans
            torch._fused_adam_([grid[a:b] for a, b in spans], [grid.grad[a:b] for a, b in spans],
                               [state["exp_avg"][a:b] for a, b in spans], [state["exp_avg_sq"][a:b] for a, b in spans],
                               [], [state["step"]] * len(spans), amsgrad=False, lr=group["lr"], beta1=group["betas"][0],
                               beta2=group["betas"][1], weight_decay=0.0, eps=group["eps"], maximize=False)


class Trainer:
    """Trains a SemanticField incrementally over a growing RayBuffer, with one persistent Adam optimiser."""

    def __init__(self, field, train_cfg: TrainConfig, render_cfg: RenderConfig, seed: int = 0, replay: bool = True):
        self.field = field
        self.cfg = train_cfg
        self.render_cfg = render_cfg
        self.replay = replay
        self.buffer = RayBuffer()
        self.rng = np.random.default_rng(seed)
        self.generator = torch.Generator(device=field.device).manual_seed(seed)
        self.optimizer = GridAdam(field, train_cfg)
        self.iterations = 0
        # the field's lattice vertices nearest to a measured surface point (back-projected depth)
        self.measured_surface = torch.zeros(field.lattice.resolution**3, dtype=torch.bool, device=field.device)
        self.skip: SkipGrid | None = None  # empty-space skipping (cfg.skip_below); None: to be built
        self._skip_built_at = 0  # the iteration count when ``skip`` was built

    def state_dict(self) -> dict:
        """What training needs to continue exactly (the field's weights and the rays are kept elsewhere):
        the optimiser, both random generators, the rays' use counts and the iteration count."""
        return {"optimizer": self.optimizer.state_dict(), "rng": self.rng.bit_generator.state,
                "generator": self.generator.get_state(), "use_counts": self.buffer.use_counts.copy(),
                "iterations": self.iterations}

    def load_state_dict(self, state: dict) -> None:
        """Continue from ``state_dict()``; the buffer must already hold the same rays again."""
        self.optimizer.load_state_dict(state["optimizer"])
        self.rng.bit_generator.state = state["rng"]
        self.generator.set_state(state["generator"])
        self.buffer.use_counts = state["use_counts"]
        self.iterations = state["iterations"]

    def reseed(self, seed: int) -> None:
        """Another random stream for the rays and samples from here on (the headroom instrument's noise ceiling)."""
        self.rng = np.random.default_rng(seed)
        self.generator.manual_seed(int(seed))

    def add_measurement(self, m: Measurement) -> None:
        """Store a new measurement; the next ``update`` trains on it."""
        self.buffer.add(m)
        self.skip = None  # a new measured surface may lie in a skipped cell
        points = torch.as_tensor(back_project(m)[0], dtype=torch.float32, device=self.field.device)
        nearest = self.field.lattice.nearest_index(points)
        self.measured_surface[nearest] = True
        self.field.surface_rays.index_add_(0, nearest, torch.ones_like(nearest, dtype=self.field.surface_rays.dtype))
        self.field.surface_views[torch.unique(nearest)] += 1
        if self.field.cfg.reached_only:  # the cells this measurement's rays reached (FieldConfig.reached_only)
            self.field.reached |= reached_vertices(self.field.lattice, *measured_rays(m, self.field.device),
                                                   self.render_cfg.near)

    def _batch(self, index: np.ndarray) -> dict[str, torch.Tensor]:
        rays = self.buffer.rays(index)
        return {k: torch.as_tensor(v, device=self.field.device) for k, v in rays.items()}

    def step(self, batch: dict[str, torch.Tensor]) -> Losses:
        """One gradient step on a batch of rays."""
        self.optimizer.zero_grad(set_to_none=False)  # zeroed in place: the grids' gradient tables are reused
        if self.skip is None:
            self.optimizer.mark_live()  # without a skip grid a gradient may reach any row
        terms = accumulate_gradient(self.field, batch, self.cfg, self.render_cfg, self.generator, self.skip)
        if not torch.isfinite(terms[0]):
            raise FloatingPointError(f"non-finite training loss {terms[0].item()} at iteration {self.iterations}")
        self.optimizer.step()
        self.iterations += 1
        return Losses(*(float(t) for t in terms))

    def update(self, iterations: int | None = None) -> list[Losses]:
        """Train ``iterations`` steps (default: the config's per-view count) after a new measurement.

        New rays: a random permutation of the newest measurement, cycled. Replay rays: drawn by
        inverse use count once per update, for all its iterations together (as the reference code
        draws one active set per view), then dealt out in batches; ``replay=False`` switches replay
        off, to show forgetting.

        Empty-space skipping (``cfg.skip_below``): after a new measurement and then every ``cfg.skip_refresh``
        iterations (counted across update calls, so that updates of one iteration each rebuild no more often than
        one long update), the lattice cells where the field's occupancy is below the threshold and no measured
        surface lies are marked empty, and samples there are not evaluated until the next refresh (they
        would only be pushed further towards 0; a surface can still grow wherever a measurement saw one).
        """
        if len(self.buffer) == 0:
            raise ValueError("the measurement set is empty: add a measurement before training")
        iterations = self.cfg.iterations_per_view if iterations is None else iterations
        newest = self.rng.permutation(self.buffer.newest_indices())
        replay = self.buffer.replay_indices(iterations * self.cfg.rays_replay, self.rng) if self.replay else np.zeros(0, int)
        replay = self.rng.permutation(replay)
        history = []
        for i in range(iterations):
            start = (i * self.cfg.rays_new) % len(newest)
            index = np.take(newest, np.arange(start, start + self.cfg.rays_new), mode="wrap")
            if len(replay):
                start = (i * self.cfg.rays_replay) % len(replay)
                index = np.concatenate([index, np.take(replay, np.arange(start, start + self.cfg.rays_replay), mode="wrap")])
            np.add.at(self.buffer.use_counts, index, 1)
            if self.cfg.skip_below is not None and (self.skip is None
                                                    or self.iterations - self._skip_built_at >= self.cfg.skip_refresh):
                self.skip = build_skip_grid(self.field, threshold=self.cfg.skip_below, also_keep=self.measured_surface)
                self.optimizer.mark_live(self.field.lattice.dilated(self.skip.keep))  # the kept cells' corners
                self._skip_built_at = self.iterations
            history.append(self.step(self._batch(index)))
        # the grids' gradient tables, each as large as its grid, are not kept between updates: planning and evaluation
        # run without them (the next update's first pass makes a new zero table: the same floats, tested)
        for grid in (self.field.grid_occ, self.field.grid_app):
            grid.grad = None
        return history
