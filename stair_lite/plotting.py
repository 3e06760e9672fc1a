"""Figures shared by the notebooks and the command line: images, scenes, hemisphere views, camera paths."""
from __future__ import annotations

import hashlib

import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from .classes import CLASS_COLOURS, CLASS_NAMES, colourise_labels
from .geometry import HEMISPHERE_RADIUS, view_to_position
from .lattice import CUBE_BOUND


# One colour per planner in every figure (the paper's planners fixed, others from a cycle that avoids these hues); a
# cross-validation variant takes the colour of the planner whose views it follows
PLANNER_COLOURS = {"stair": "#d62728", "exploration": "#1f77b4", "fixed": "#7f7f7f", "max_distance": "#2ca02c",
                   "uniform": "#bcbd22", "ste": "#9467bd", "stair_soft": "#ff7f0e", "stair_semantic": "#8c564b",
                   "coverage": "#17becf", "fisher": "#e377c2", "stair_unknown": "#ff9896", "stair_reference": "#c49c94"}
_OTHER_COLOURS = ("#393b79", "#637939", "#8c6d31", "#843c39", "#7b4173", "#3182bd", "#31a354", "#756bb1")


def planner_colour(name: str) -> str:
    """The colour of a planner or sweep variant, the same in every figure of the package."""
    from .experiments import CROSS_VALIDATION

    name = CROSS_VALIDATION.get(name, name)
    if name in PLANNER_COLOURS:
        return PLANNER_COLOURS[name]
    return _OTHER_COLOURS[int(hashlib.sha256(name.encode()).hexdigest(), 16) % len(_OTHER_COLOURS)]


def show_measurement(m, title: str = "", axes=None):
    """rgb, depth and labels of a Measurement side by side."""
    if axes is None:
        _, axes = plt.subplots(1, 3, figsize=(11, 3.6))
    axes[0].imshow(m.rgb)
    axes[0].set_title(f"{title} rgb".strip())
    depth = np.ma.masked_equal(m.depth, 0.0)
    im = axes[1].imshow(depth, cmap="viridis")
    plt.colorbar(im, ax=axes[1], fraction=0.046, label="z-depth [m]")
    axes[1].set_title("depth (blank: no hit)")
    axes[2].imshow(colourise_labels(m.labels))
    axes[2].set_title("labels")
    for ax in axes:
        ax.set_axis_off()
    label_legend(axes[2], m.labels)
    return axes


def label_legend(ax, *label_images):
    """A legend of the class colours (``colourise_labels``) of every class that occurs in the label images, to the
    right of ``ax``."""
    present = np.unique(np.concatenate([np.asarray(labels).reshape(-1) for labels in label_images]))
    handles = [plt.Rectangle((0, 0), 1, 1, color=CLASS_COLOURS[c], ec="k", lw=0.3) for c in present]
    ax.legend(handles, [CLASS_NAMES[c] for c in present], loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7)


def draw_mesh(ax, mesh, max_faces: int = 4000, alpha: float = 1.0, colour=None):
    """Draw a trimesh on a 3-D axis with its face colours (or one ``colour``), thinning very dense meshes."""
    faces = mesh.faces
    step = max(1, len(faces) // max_faces)
    tris = mesh.vertices[faces[::step]]
    if colour is None and mesh.visual.kind == "face":
        colours = mesh.visual.face_colors[::step, :3] / 255.0
    else:
        colours = np.broadcast_to(np.asarray(colour if colour is not None else (0.6, 0.6, 0.6), float), (len(tris), 3))
    ax.add_collection3d(Poly3DCollection(tris, facecolors=colours, edgecolor="none", alpha=alpha))


def draw_scene(ax, scene, ground: bool = False):
    """Draw a scene's objects (and optionally its ground) on a 3-D axis with equal scaling."""
    for mesh in scene.object_meshes:
        draw_mesh(ax, mesh)
    if ground:
        draw_mesh(ax, scene.ground, alpha=0.3)
    set_equal_3d(ax, CUBE_BOUND, z_range=(0.0, 1.2))


def set_equal_3d(ax, half: float, z_range=(0.0, None)):
    """Equal-aspect cube of half-width ``half`` around the origin (z from 0 by default)."""
    ax.set_xlim(-half, half)
    ax.set_ylim(-half, half)
    ax.set_zlim(z_range[0], z_range[1] if z_range[1] is not None else 2 * half)
    ax.set_box_aspect((2, 2, 2 if z_range[1] is None else (z_range[1] - z_range[0]) / half))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")


def draw_hemisphere(ax, radius: float = HEMISPHERE_RADIUS, alpha: float = 0.15):
    """A wireframe of the hemispherical action space."""
    el, az = np.meshgrid(np.linspace(0, np.pi / 2, 7), np.linspace(0, 2 * np.pi, 25))
    p = view_to_position(el, az, radius)
    ax.plot_wireframe(p[..., 0], p[..., 1], p[..., 2], color="grey", alpha=alpha, linewidth=0.6)


def draw_cameras(ax, poses, colour="tab:orange", size: float = 0.25, path: bool = False, labels: bool = False):
    """Camera centres with a short viewing-direction arrow each; optionally joined as a path and numbered."""
    poses = np.asarray(poses)
    centres, forwards = poses[:, :3, 3], poses[:, :3, 2]
    ax.quiver(*centres.T, *(forwards * size).T, color=colour, linewidth=1.2)
    ax.scatter(*centres.T, color=colour, s=12, depthshade=False)
    if path:
        ax.plot(*centres.T, color=colour, linewidth=1.5)
    if labels:
        for i, c in enumerate(centres):
            ax.text(*c, str(i + 1), fontsize=8)


def hemisphere_scatter(ax, views, values=None, cmap="magma", s=18, **kw):
    """Top-down map of views (elevation, azimuth): x/y of the camera centre, coloured by ``values``."""
    views = np.asarray(views)
    p = view_to_position(views[:, 0], views[:, 1], 1.0)
    sc = ax.scatter(p[:, 0], p[:, 1], c=values, cmap=cmap if values is not None else None, s=s, **kw)
    ax.add_patch(plt.Circle((0, 0), 1.0, fill=False, color="grey", lw=0.8))
    ax.set_aspect("equal")
    ax.set_xlim(-1.1, 1.1)
    ax.set_ylim(-1.1, 1.1)
    ax.set_xlabel("x / r (top-down)")
    ax.set_ylabel("y / r")
    return sc


def plot_mission_metrics(records, axes=None, label: str | None = None, colour=None):
    """Target-only PSNR and mesh F1 against the number of measurements, from a mission's step records."""
    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(10, 3.5))
    steps = [r["step"] for r in records]
    axes[0].plot(steps, [r["psnr"] for r in records], marker="o", label=label, color=colour)
    axes[1].plot(steps, [r["f1"] for r in records], marker="o", label=label, color=colour)
    axes[0].set_ylabel("target-only PSNR [dB]")
    axes[1].set_ylabel("target mesh F1 (1 cm)")
    for ax in axes:
        ax.set_xlabel("measurements")
        ax.grid(alpha=0.3)
    return axes


def plot_camera_path(scene, records, ax=None, title: str = ""):
    """The scene with the mission's camera path on the hemisphere, views numbered in order."""
    if ax is None:
        ax = plt.figure(figsize=(6, 6)).add_subplot(projection="3d")
    draw_scene(ax, scene)
    draw_hemisphere(ax)
    draw_cameras(ax, np.array([r["pose"] for r in records]), path=True, labels=True)
    set_equal_3d(ax, 2.1, z_range=(0.0, 2.1))
    ax.set_title(title)
    return ax


def plot_views_top_down(ax, records, title: str = "", colour="tab:orange"):
    """A mission's views seen from above the hemisphere: the camera centres (x, y) / r joined in order and numbered,
    with rings at 0, 30 and 60 deg elevation (radius cos(elevation)), so that elevation reads off the distance from
    the centre (the top view)."""
    views = np.radians([r["view_deg"] for r in records])
    for elevation in (0, 30, 60):
        radius = np.cos(np.radians(elevation))
        ax.add_patch(plt.Circle((0, 0), radius, fill=False, color="grey", lw=0.6, ls="-" if elevation == 0 else ":"))
        ax.annotate(f"{elevation} deg", (radius * np.cos(-0.6), radius * np.sin(-0.6)), fontsize=6, color="grey")
    p = view_to_position(views[:, 0], views[:, 1], 1.0)
    ax.plot(p[:, 0], p[:, 1], "-", color=colour, lw=0.8, alpha=0.6)
    ax.scatter(p[:, 0], p[:, 1], color=colour, s=60, edgecolor="k", lw=0.5, zorder=3)
    for step, (x, y) in enumerate(p[:, :2], start=1):
        ax.annotate(str(step), (x, y), fontsize=7, ha="center", va="center", zorder=4)
    ax.set_aspect("equal")
    ax.set_xlim(-1.1, 1.1)
    ax.set_ylim(-1.1, 1.1)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title)
    return ax


def plot_sweep_curves(rows, metric: str = "psnr", variants=None, axes=None, ylabel: str | None = None,
                      title: str | None = None, legend: bool = True):
    """One panel per scene, one line per variant: mean over seeds with a shaded +-1 std band (paper Fig. 4).
    ``title`` replaces the scene's name as the panels' title; ``legend=False`` leaves the legend to the caller.

    As in the paper's Fig. 5, a cross-validation variant is dashed and shares the colour of the variant
    whose measurements it uses (``stair_explicit`` that of ``stair``, ``ste_implicit`` that of ``ste``).
    """
    from .experiments import CROSS_VALIDATION, curves

    data = curves(rows, metric)
    scenes = sorted({s for s, _ in data})
    variants = variants or sorted({v for _, v in data})
    if axes is None:
        _, axes = plt.subplots(1, len(scenes), figsize=(4 * len(scenes), 3.3), squeeze=False)
        axes = axes[0]
    colour = {v: planner_colour(v) for v in variants}
    for ax, scene in zip(axes, scenes):
        for variant in variants:
            if (scene, variant) not in data:
                continue
            steps, mean, std, n = data[(scene, variant)]
            style = "--" if variant in CROSS_VALIDATION else "-"
            ax.plot(steps, mean, style, color=colour[variant], label=f"{variant} (n={n})")
            ax.fill_between(steps, mean - std, mean + std, color=colour[variant], alpha=0.15)
        ax.set_title(title or scene)
        ax.set_xlabel("measurements")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(ylabel or metric)
    if legend:
        next((ax for ax in axes[::-1] if ax.lines), axes[-1]).legend(fontsize=7, loc="lower right")
    return axes


def plot_headroom(headroom, metrics=("f1", "psnr_clean"), utility: str = "stair", axes=None):
    """The headroom instrument's result (headroom.py): the realised gain of each spread candidate on the
    hemisphere (seen from above; every measured planner's pick marked), then per metric the gain against ``utility``'s
    score with its rank correlation (stream 0, the mission's own training stream)."""
    if axes is None:
        fig = plt.figure(figsize=(4.2 * (1 + len(metrics)), 4.2))
        axes = [fig.add_subplot(1, 1 + len(metrics), 1, projection="polar")] + [
            fig.add_subplot(1, 1 + len(metrics), 2 + i) for i in range(len(metrics))]
    spread = [r for r in headroom.rows if r["kind"] == "spread" and int(r.get("stream", 0)) == 0]
    picks = {kind: next(r for r in headroom.rows if r["kind"] == kind) for kind in headroom.utilities}
    shapes = "*^sDvPXo"

    def polar(rows):
        return np.radians([r["azimuth_deg"] for r in rows]), [90 - r["elevation_deg"] for r in rows]

    theta, radius = polar(spread)
    im = axes[0].scatter(theta, radius, c=[r[f"gain_{metrics[0]}"] for r in spread], cmap="viridis", s=40)
    for i, (kind, r) in enumerate(picks.items()):
        t, rad = polar([r])
        axes[0].scatter(t, rad, marker=shapes[i % len(shapes)], s=120, facecolor="none", edgecolor=planner_colour(kind),
                        linewidth=1.5, label=kind)
    axes[0].set_ylim(0, 90)
    axes[0].set_yticklabels([])
    axes[0].set_title(f"{headroom.scene}, after {headroom.after} views: {metrics[0]} gain\nof each next view (centre: top, rim: horizon)",
                      fontsize=9, pad=14)
    axes[0].legend(fontsize=7, loc="lower left", bbox_to_anchor=(-0.25, -0.2))
    plt.colorbar(im, ax=axes[0], fraction=0.046, pad=0.12)
    for ax, metric in zip(axes[1:], metrics):
        ax.scatter([r[f"u_{utility}"] for r in spread], [r[f"gain_{metric}"] for r in spread], color="grey", s=18, label="spread")
        for i, (kind, r) in enumerate(picks.items()):
            ax.scatter(r[f"u_{utility}"], r[f"gain_{metric}"], marker=shapes[i % len(shapes)], s=90, color=planner_colour(kind),
                       label=f"{kind}'s pick")
        rho = headroom.correlations[utility][metric]
        ax.set_title(f"{metric} gain vs {utility}'s utility (Spearman {'-' if rho is None else f'{rho:+.2f}'})", fontsize=9)
        ax.set_xlabel(f"{utility}'s utility")
        ax.set_ylabel(f"realised {metric} gain")
        ax.axhline(0, color="k", linewidth=0.5)
    axes[1].legend(fontsize=7)
    return axes
