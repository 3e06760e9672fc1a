"""Figures of notebook 04 (the entropy utility)."""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..classes import colourise_labels
from ..plotting import label_legend


def plot_uncertainty_panels(views, camera_images, h_maps, labels, target_masks):
    """One row per view: the camera image, the per-ray entropy H(r) with its sum U_er (Eq. 12), the rendered
    labels and H(r) on the target mask with its sum U_et (Eq. 13). Views are (elevation, azimuth) [rad]."""
    fig, axes = plt.subplots(len(views), 4, figsize=(11, 2.9 * len(views)), squeeze=False)
    vmax = h_maps.max()
    for row, view, image, h, label, mask in zip(axes, views, camera_images, h_maps, labels, target_masks):
        row[0].imshow(image)
        row[0].set_title(f"el {np.degrees(view[0]):.0f}, az {np.degrees(view[1]):.0f} deg: rgb", fontsize=9)
        im = row[1].imshow(h, cmap="magma", vmin=0, vmax=vmax)
        row[1].set_title(f"H(r): U_er = {h.sum():.0f}", fontsize=9)
        row[2].imshow(colourise_labels(label))
        row[2].set_title("rendered labels (argmax S)", fontsize=9)
        row[3].imshow(h * mask, cmap="magma", vmin=0, vmax=vmax)
        row[3].set_title(f"H(r) on targets: U_et = {(h * mask).sum():.0f}", fontsize=9)
        for ax in row:
            ax.set_axis_off()
    label_legend(axes[0, 2], *labels)
    fig.colorbar(im, ax=axes, fraction=0.02, label="H(r) [nats]")
    return fig
