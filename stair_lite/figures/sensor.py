"""Figures of notebook 01 (the scene and the sensor)."""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import trimesh

from ..geometry import HEMISPHERE_RADIUS, view_to_position
from ..plotting import draw_hemisphere, hemisphere_scatter, set_equal_3d


def plot_action_space(view_sets, centre, test_views):
    """Left: ``view_sets`` ([(views, colour, label), ...]) on the 3-D hemisphere with ``centre`` starred;
    right: the test views seen from above, coloured by elevation."""
    fig = plt.figure(figsize=(12, 4.8))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    draw_hemisphere(ax)
    for views, colour, label in view_sets:
        ax.scatter(*view_to_position(views[:, 0], views[:, 1], HEMISPHERE_RADIUS).T, s=8, color=colour, label=label,
                   depthshade=False)
    ax.scatter(*view_to_position(*centre, HEMISPHERE_RADIUS), s=60, marker="*", color="black")
    set_equal_3d(ax, 2.1, z_range=(0, 2.1))
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("the hemispherical action space")
    ax = fig.add_subplot(1, 2, 2)
    hemisphere_scatter(ax, test_views, values=np.degrees(test_views[:, 0]), cmap="viridis")
    ax.set_title(f"the {len(test_views)} test views, top-down (colour: elevation in deg)")
    return fig


def ray_cast_distances(scene, measurement, n_pixels: int, rng: np.random.Generator):
    """An independent check of a depth image: cast the rays of ``n_pixels`` random hit pixels against the
    scene's meshes with trimesh. Returns the rendered depth, the ray-cast z-depth (along the optical axis)
    and the ray-cast range (along the ray) per pixel; NaN where the cast missed."""
    merged = trimesh.util.concatenate([mesh for mesh, _ in scene.labelled_meshes()])
    K, pose = measurement.intrinsics, measurement.pose
    hit_pixels = np.argwhere(measurement.depth > 0)  # (row v, column u)
    v_px, u_px = hit_pixels[rng.choice(len(hit_pixels), n_pixels, replace=False)].T
    rays_cam = np.stack([(u_px + 0.5 - K.cx) / K.fx, (v_px + 0.5 - K.cy) / K.fy, np.ones(len(u_px))], axis=1)
    dirs = rays_cam @ pose[:3, :3].T
    origins = np.repeat(pose[None, :3, 3], len(dirs), axis=0)
    locations, index_ray, _ = merged.ray.intersects_location(origins, dirs, multiple_hits=False)
    hit_point = np.full((len(dirs), 3), np.nan)
    hit_point[index_ray] = locations
    z_depth = (hit_point - origins) @ pose[:3, 2]
    ray_range = np.linalg.norm(hit_point - origins, axis=1)
    return measurement.depth[v_px, u_px], z_depth, ray_range


def plot_depth_against_ray_cast(rendered, z_depth, ray_range):
    """The rendered depth against both ray-cast distances, with the diagonal."""
    fig, ax = plt.subplots(figsize=(5, 4.2))
    ax.scatter(z_depth, rendered, s=6, label="vs ray-cast z-depth")
    ax.scatter(ray_range, rendered, s=6, label="vs ray-cast range")
    lim = [np.nanmin(rendered), np.nanmax(ray_range)]
    ax.plot(lim, lim, "k--", linewidth=0.8)
    ax.set_xlabel("ray-cast distance [m]")
    ax.set_ylabel("rendered depth [m]")
    ax.legend()
    return fig
