"""Figures of notebook 07 (when the labels lie)."""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..classes import CLASS_COLOURS, CLASS_NAMES, colourise_labels


def object_box(labels: np.ndarray, margin: int = 12) -> tuple[slice, slice]:
    """Rows and columns of the smallest box around every object pixel, grown by ``margin`` pixels."""
    rows, cols = np.nonzero(labels)
    if not len(rows):
        return slice(None), slice(None)
    h, w = labels.shape
    return (slice(max(rows.min() - margin, 0), min(rows.max() + margin + 1, h)),
            slice(max(cols.min() - margin, 0), min(cols.max() + margin + 1, w)))


def plot_label_row(panels: dict[str, np.ndarray], rgb: np.ndarray | None = None, size: float = 2.6):
    """One row of label images (H, W) with their titles, after the camera image if given, and a class legend;
    all cropped to the objects of the first panel."""
    n = len(panels) + (rgb is not None)
    fig, axes = plt.subplots(1, n, figsize=(size * n, size + 0.4), squeeze=False)
    axes = list(axes[0])
    box = object_box(next(iter(panels.values())))
    if rgb is not None:
        axes[0].imshow(rgb[box])
        axes[0].set_title("rgb", fontsize=9)
        axes = axes[1:]
    for ax, (title, labels) in zip(axes, panels.items()):
        ax.imshow(colourise_labels(labels[box]))
        ax.set_title(title, fontsize=9)
    for ax in fig.axes:
        ax.set_axis_off()
    handles = [plt.Rectangle((0, 0), 1, 1, facecolor=c, edgecolor="k", linewidth=0.3) for c in CLASS_COLOURS]
    fig.legend(handles, CLASS_NAMES, loc="lower center", ncol=len(CLASS_NAMES), fontsize=8, frameon=False)
    fig.subplots_adjust(bottom=0.15, wspace=0.05)
    return fig


def plot_map_beliefs(truth: np.ndarray, beliefs: dict[str, dict[str, np.ndarray]], vmax: float = np.log(7)):
    """Per map (one row each): its rendered labels (argmax S), the target probability p_T and the class entropy
    H_sem; ``truth`` (H, W) is shown first in every row for comparison."""
    fig, axes = plt.subplots(len(beliefs), 4, figsize=(11, 2.9 * len(beliefs)), squeeze=False, layout="constrained")
    for row, (name, b) in zip(axes, beliefs.items()):
        row[0].imshow(colourise_labels(truth))
        row[0].set_title("exact labels", fontsize=9)
        row[1].imshow(colourise_labels(b["labels"]))
        row[1].set_title(f"{name}: argmax S", fontsize=9)
        p = row[2].imshow(b["p_target"], cmap="viridis", vmin=0, vmax=1)
        row[2].set_title(f"{name}: p_T", fontsize=9)
        h = row[3].imshow(b["h_sem"], cmap="magma", vmin=0, vmax=vmax)
        row[3].set_title(f"{name}: H_sem, mean {b['h_sem'].mean():.3f}", fontsize=9)
        for ax in row:
            ax.set_axis_off()
    fig.colorbar(p, ax=axes[:, 2], shrink=0.8, label="p_T")
    fig.colorbar(h, ax=axes[:, 3], shrink=0.8, label="H_sem [nats]")
    return fig
