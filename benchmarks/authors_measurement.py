"""The measurement input of ``authors_step.py``: our scene's top view (and a second view) at the paper preset, with
everything the authors' planner needs to ingest it, in one npz:

  rgb      (H, W, 3) float32 in [0, 1]   (their record_rgb_measurement wants 0..255: the harness multiplies by 255)
  depth    (H, W)    float32 z-depth [m], 0 where nothing was hit (their depth is z-depth too)
  labels   (H, W)    uint8 class ids 0..6 in the paper's order, the ids of their LABELS["shapenet"]
  pose     (4, 4)    float64 OpenCV camera-to-world; the harness turns it into the Gazebo pose their record_step expects
  K        (4,)      fx, fy, cx, cy [pixels], pixel centres at (u + 0.5, v + 0.5) as in their get_ray_directions
  view     (2,)      (elevation, azimuth) [rad]
  targets  (k,)      the scene's target class ids (their --target_class_id)
  check_pix (n,), check_xyz (n, 3): object pixels and our back-projected world points there (the harness derives them
                     again from their rays and our depth: a check of the pose and intrinsics mapping)

With ``--second-view ELEV_DEG AZ_DEG`` (default 45 0) a second measurement is stored under the same names with suffix 2.

Run: python benchmarks/authors_measurement.py [--out runs/authors/measurement.npz]"""
from __future__ import annotations

import argparse
import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import numpy as np  # noqa: E402

from stair_lite.config import get_preset  # noqa: E402
from stair_lite.geometry import TOP_VIEW  # noqa: E402
from stair_lite.lattice import CUBE_BOUND  # noqa: E402
from stair_lite.measurement import back_project  # noqa: E402
from stair_lite.mission import World  # noqa: E402


def pack(m, view, suffix=""):
    intr = m.intrinsics
    labels = np.asarray(m.labels)
    depth = np.asarray(m.depth, dtype=np.float32)
    hit = depth.reshape(-1) > 0
    obj = hit & (labels.reshape(-1) != 0)
    pts, _, _ = back_project(m)  # every pixel with a hit, row-major order
    hit_idx = np.flatnonzero(hit)
    rng = np.random.default_rng(0)
    obj_idx = np.flatnonzero(obj)
    pick = np.sort(rng.choice(obj_idx, size=min(2000, len(obj_idx)), replace=False))
    pts_of = {int(p): i for i, p in enumerate(hit_idx)}
    check_xyz = pts[[pts_of[int(p)] for p in pick]]
    out = {
        "rgb": np.asarray(m.rgb, dtype=np.float32),
        "depth": depth,
        "labels": labels.astype(np.uint8),
        "pose": np.asarray(m.pose, dtype=np.float64),
        "K": np.array([intr.fx, intr.fy, intr.cx, intr.cy], dtype=np.float64),
        "view": np.asarray(view, dtype=np.float64),
        "check_pix": pick.astype(np.int64),
        "check_xyz": check_xyz.astype(np.float64),
    }
    obj_pts = pts[labels.reshape(-1)[hit_idx] != 0]
    print(f"view{suffix or '1'} (deg) {np.degrees(view).round(2).tolist()}: image {intr.width}x{intr.height}, "
          f"fx={intr.fx:.2f} fy={intr.fy:.2f} cx={intr.cx} cy={intr.cy}; camera at {np.round(m.pose[:3, 3], 4).tolist()}")
    print(f"  pixels: hit {hit.mean():.3f}, object {obj.mean():.3f}; depth on objects "
          f"{depth.reshape(-1)[obj].min():.3f}..{depth.reshape(-1)[obj].max():.3f} m (mean {depth.reshape(-1)[obj].mean():.3f})")
    print(f"  labels present: {sorted(set(np.unique(labels).tolist()))}")
    if len(obj_pts):
        print(f"  visible object points: x {obj_pts[:, 0].min():.3f}..{obj_pts[:, 0].max():.3f}, "
              f"y {obj_pts[:, 1].min():.3f}..{obj_pts[:, 1].max():.3f}, z {obj_pts[:, 2].min():.3f}..{obj_pts[:, 2].max():.3f}; "
              f"max |xyz| {np.linalg.norm(obj_pts, axis=1).max():.3f} m")
    return {k + suffix: v for k, v in out.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="scene1")
    ap.add_argument("--out", default="runs/authors/measurement.npz")
    ap.add_argument("--second-view", nargs=2, type=float, metavar=("ELEV_DEG", "AZ_DEG"), default=(45.0, 0.0),
                    help="a second view stored with suffix 2 (default 45 0); give -1 -1 for none")
    args = ap.parse_args()

    world = World.build(args.scene, get_preset("paper"))
    print(f"scene {args.scene}: targets {world.targets}; our scene cube [-{CUBE_BOUND}, {CUBE_BOUND}]^3 m")
    for mesh, cls in world.scene.labelled_meshes()[1:]:
        lo, hi = mesh.bounds
        print(f"  object class {cls}: extents {np.round(hi - lo, 3).tolist()} m, centre {np.round((lo + hi) / 2, 3).tolist()}")
    view = np.array(TOP_VIEW)
    data = pack(world.measure(view, 1), view)
    if args.second_view[0] >= 0:
        view2 = np.radians(np.array(args.second_view, dtype=np.float64))
        data.update(pack(world.measure(view2, 2), view2, suffix="2"))
    data["targets"] = np.asarray(world.targets, dtype=np.int64)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    np.savez_compressed(args.out, **data)
    print(f"wrote {args.out}: {sorted(data)}")


if __name__ == "__main__":
    main()
