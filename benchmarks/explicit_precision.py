"""Why does the voxel map's F1 fall late in `stair_explicit` (STAIR's views fused into STE's voxel map)?

Run: .venv/bin/python benchmarks/explicit_precision.py [--results data/results/comparison_lite] [--scenes scene1,scene3]
     [--seeds 2]
Replays the stored views of the `stair` and `ste` cells into a fresh voxel map of the preset recorded there and prints,
per step: the occupied target voxels, the share of them whose centre lies farther than half a voxel from the
ground-truth target surface (a shell thicker than the surface), and their median distance to it [cm]. The stored
precision and completeness per step (averaged over the cells) are printed beside.
"""
import argparse
import json
from pathlib import Path

import numpy as np
import torch
from scipy.spatial import cKDTree

import stair_lite  # noqa: F401
from stair_lite.config import get_preset
from stair_lite.maps import EXPLICIT
from stair_lite.metrics import OCCUPIED
from stair_lite.mission import World, build_map


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--results", default="data/results/comparison_lite")
    parser.add_argument("--scenes", default="scene1,scene3")
    parser.add_argument("--seeds", type=int, default=2)
    args = parser.parse_args()
    root = Path(args.results)
    for scene in args.scenes.split(","):
        for variant, evaluated in (("stair", "stair_explicit"), ("ste", "ste")):
            for seed in range(args.seeds):
                stored = json.loads((root / scene / variant / f"seed{seed}" / "metrics.json").read_text())
                preset = get_preset(stored["config"]["preset"])
                world = World.build(scene, preset)
                surface = cKDTree(world.evaluator.gt_points)
                voxel_map = build_map(EXPLICIT, preset)
                r, cells = voxel_map.cfg.resolution, []
                for record in stored["steps"]:
                    voxel_map.integrate(world.measure(record["view_rad"], record["step"]))
                    solid = (voxel_map.probability > OCCUPIED) & torch.isin(voxel_map.labels, torch.as_tensor(world.targets))
                    k, j, i = np.unravel_index(np.flatnonzero(solid.cpu().numpy()), (r, r, r))
                    centres = -voxel_map.cfg.bound + (np.stack([i, j, k], axis=1) + 0.5) * voxel_map.voxel
                    distance, _ = surface.query(centres)
                    cells.append(f"{len(centres)}:{(distance > voxel_map.voxel / 2).mean():.2f}:{100 * np.median(distance):.2f}")
                scores = json.loads((root / scene / evaluated / f"seed{seed}" / "metrics.json").read_text())["steps"]
                print(f"{scene} {variant}'s views, seed {seed} (voxels : off the surface : median cm): {' '.join(cells)}")
                for score in ("precision", "completeness"):
                    values = " ".join(f"{s[score]:.3f}" for s in scores)
                    print(f"    {evaluated} {score}: {values}", flush=True)


if __name__ == "__main__":
    main()
