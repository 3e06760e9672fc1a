"""Incremental training of the semantic field (paper Sec. III-B, Eq. 6-9).

Introduced in notebook 02 (one fit) and notebook 03 (incremental, with replay).
After each new measurement the field trains a fixed number of iterations; each batch is half rays
of the newest measurement and half rays replayed from all earlier ones, a ray's chance of being
replayed inversely proportional to how often it has been used (paper Sec. III-B).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from .config import RenderConfig, TrainConfig
from .geometry import pixel_rays
from .measurement import Measurement
from .rendering import render_rays

LOG_CLAMP = 1e-6  # probabilities are clamped before log(): cross entropy stays finite


class RayBuffer:
    """Every ray measured so far (origin, direction, rgb, depth, label), with per-ray use counts."""

    def __init__(self):
        self._parts: list[dict[str, np.ndarray]] = []
        self.use_counts = np.zeros(0, dtype=np.int64)
        self.view_index = np.zeros(0, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.use_counts)

    @property
    def n_views(self) -> int:
        return len(self._parts)

    def add(self, m: Measurement) -> None:
        """Append all rays of one measurement (checked by the Measurement record itself)."""
        origins, dirs = pixel_rays(m.intrinsics, m.pose)
        part = {
            "origins": origins.astype(np.float32),
            "dirs": dirs.astype(np.float32),
            "rgb": m.rgb.reshape(-1, 3).astype(np.float32),
            "depth": m.depth.reshape(-1).astype(np.float32),
            "labels": m.labels.reshape(-1).astype(np.int64),
        }
        self._parts.append(part)
        self._all = {k: np.concatenate([p[k] for p in self._parts]) for k in part}
        self.use_counts = np.concatenate([self.use_counts, np.zeros(len(origins), dtype=np.int64)])
        self.view_index = np.concatenate([self.view_index, np.full(len(origins), self.n_views - 1)])

    def rays(self, index: np.ndarray) -> dict[str, np.ndarray]:
        """The rays at the given buffer indices."""
        return {k: v[index] for k, v in self._all.items()}

    def newest_indices(self) -> np.ndarray:
        return np.flatnonzero(self.view_index == self.n_views - 1)

    def replay_indices(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Draw ``n`` distinct rays of earlier views, P(ray) proportional to 1 / (1 + times used).

        Weighted sampling without replacement by the exponential-keys method: key = E / weight with
        E ~ Exp(1); the n smallest keys are a weighted sample (Efraimidis and Spirakis).
        """
        old = np.flatnonzero(self.view_index < self.n_views - 1)
        if len(old) == 0 or n <= 0:
            return np.zeros(0, dtype=np.int64)
        keys = rng.exponential(size=len(old)) * (1.0 + self.use_counts[old])
        n = min(n, len(old))
        return old[np.argpartition(keys, n - 1)[:n]]


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
        mlp_params = list(field.occ_mlp.parameters()) + list(field.rgb_mlp.parameters())
        self.optimizer = torch.optim.Adam(
            [{"params": [field.grid], "lr": train_cfg.lr_grid}, {"params": mlp_params, "lr": train_cfg.lr_mlp}],
            betas=(0.9, 0.99),
            fused=True,
        )
        self.iterations = 0

    def add_measurement(self, m: Measurement) -> None:
        """Store a new measurement; the next ``update`` trains on it."""
        self.buffer.add(m)

    def _batch(self, index: np.ndarray) -> dict[str, torch.Tensor]:
        rays = self.buffer.rays(index)
        return {k: torch.as_tensor(v, device=self.field.device) for k, v in rays.items()}

    def step(self, batch: dict[str, torch.Tensor]) -> Losses:
        """One gradient step on a batch of rays."""
        out = render_rays(
            self.field, batch["origins"], batch["dirs"], self.render_cfg, generator=self.generator, depth=batch["depth"]
        )
        total, l_rgb, l_depth, l_sem = loss_terms(out, batch, self.cfg)
        if not torch.isfinite(total):
            raise FloatingPointError(f"non-finite training loss {total.item()} at iteration {self.iterations}")
        self.optimizer.zero_grad(set_to_none=True)
        total.backward()
        self.optimizer.step()
        self.iterations += 1
        return Losses(total.item(), l_rgb.item(), l_depth.item(), l_sem.item())

    def update(self, iterations: int | None = None) -> list[Losses]:
        """Train ``iterations`` steps (default: the config's per-view count) after a new measurement.

        New rays: a random permutation of the newest measurement, cycled. Replay rays: drawn by
        inverse use count once per update, for all its iterations together (as the reference code
        draws one active set per view), then dealt out in batches; ``replay=False`` switches replay
        off, to show forgetting.
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
            history.append(self.step(self._batch(index)))
        return history
