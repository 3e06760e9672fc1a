"""Figures of notebook 05 (the planning loop)."""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from ..classes import colourise_labels
from ..evaluation import psnr
from ..geometry import view_to_pose, view_to_position
from ..plotting import hemisphere_scatter, label_legend
from ..rendering import render_image
from ..simulator import target_only_image


def show_beliefs(field, simulator, render_cfg, targets, views, names, suptitle):
    """What the map believes at each view, beside the camera: one row per view with the camera image, the
    map's colour and class renders, and its target-only render against the true target-only image (PSNR in
    the title). Renders at the simulator's intrinsics. Returns per view the map's render (``belief``), its
    ``target_only`` image, the camera's measurement (``truth``) and the true target-only image (``gt``)."""
    fig, axes = plt.subplots(len(views), 5, figsize=(11, 2.3 * len(views)), squeeze=False)
    beliefs = []
    for row, view, name in zip(axes, views, names):
        pose = view_to_pose(*view)
        truth = simulator.render(pose)
        belief = render_image(field, simulator.intrinsics, pose, render_cfg)
        target_only = render_image(field, simulator.intrinsics, pose, render_cfg, targets=targets)["rgb"]
        gt_target_only = target_only_image(truth, targets)
        panels = [(truth.rgb, f"{name}: camera"), (belief["rgb"], "map: colour"),
                  (colourise_labels(belief["labels"]), "map: class argmax"),
                  (target_only, f"map: target only ({psnr(target_only, gt_target_only):.1f} dB)"),
                  (gt_target_only, "truth: target only")]
        for ax, (image, title) in zip(row, panels):
            ax.imshow(image)
            ax.set_title(title, fontsize=8)
            ax.set_axis_off()
        beliefs.append({"belief": belief, "target_only": target_only, "truth": truth, "gt": gt_target_only})
    label_legend(axes[0, 2], *[b["belief"]["labels"] for b in beliefs])
    fig.suptitle(suptitle, fontsize=10)
    plt.tight_layout()
    return beliefs


def show_decision(decision, visited, epsilon: float, title: str):
    """A planner's decision seen from above: exploitation U_et, weighted exploration epsilon U_er and the
    utility U (Eq. 15) of every candidate, the visited views (squares) and the chosen view (star)."""
    s = decision.scores
    fig, axes = plt.subplots(1, 3, figsize=(12, 4))
    v = np.array(visited)
    visited_xy = view_to_position(v[:, 0], v[:, 1], 1.0)
    chosen_xy = view_to_position(*decision.view, 1.0)
    for ax, values, name in zip(axes, [s.exploitation, epsilon * s.exploration, s.utility],
                                ["exploitation $U_{et}$", r"exploration $\epsilon U_{er}$", "utility $U$"]):
        sc = hemisphere_scatter(ax, decision.candidates, values, s=16)
        plt.colorbar(sc, ax=ax, fraction=0.046)
        ax.scatter(visited_xy[:, 0], visited_xy[:, 1], marker="s", s=60, facecolors="none", edgecolors="tab:cyan", lw=2,
                   label="visited")
        ax.scatter(*chosen_xy[:2], marker="*", s=250, color="lime", edgecolors="black", label="chosen")
        ax.set_title(name)
    axes[0].legend(loc="lower left", fontsize=7)
    fig.suptitle(title)
    plt.tight_layout()
    return fig
