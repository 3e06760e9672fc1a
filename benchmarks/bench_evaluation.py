"""The paper's evaluation protocol on this CPU, phase by phase (the speed issue's "evaluation in seconds").

A paper-preset field is trained on three views of scene 1 (a cut schedule: 60 iterations of 512 + 512 rays per
view: a cloudy field, far more samples to read than a trained one), or ``--mission`` names a stored mission folder
whose checkpoint holds the state of a real mission (e.g. one of the paper-scale comparison's, on the machine that ran
it: checkpoints are not committed), and the evaluator's phases are timed: the target skip grid, the target-only
renders of the test views (100 at 400 x 400 at the paper preset), the phantom share (the field's occupancy on the
lattice below the ground), the target mesh (a 256^3 lattice) and its surface
samples (1e6), and the nearest-distance scores, both with scipy's default KD-tree queried in the samples' order and as
the evaluation takes them (``evaluation.point_tree``, queries in ``spatial_order``: the same scores; the figure is the
ratio). Medians over ``--repeats``. For the renders, also what they sample: the
live rays per view, the window samples and kept samples per live ray (``rendering.live_rays``, ``kept_window_samples``),
the time of reading the field at the kept samples of five views (what no cull of samples removes), the renders with
the colour MLP in cache-sized blocks against one pass over the whole batch (its form before), and the share of
those samples that lie behind the point where their ray turned opaque (transmittance below 1e-4 in the composite
without the ground's underside, the more transparent of the two): the most that stopping rays once opaque could save.

Run: .venv/bin/python benchmarks/bench_evaluation.py [--repeats 3] [--views 100] [--preset paper] [--mission FOLDER]
"""
import argparse
import json
import shutil
import statistics
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from scipy.spatial import cKDTree

import stair_lite  # noqa: F401
from stair_lite.config import get_preset
from stair_lite.evaluation import GROUND_CUT_Z, mesh_scores_from_points, sample_surface
from stair_lite.field import mlp_on_parts
from stair_lite.geometry import TOP_VIEW, fibonacci_hemisphere
from stair_lite.maps import IMPLICIT
from stair_lite.mission import Mission, MissionConfig, World, build_map
from stair_lite.results_folder import CHECKPOINT_FILE, METRICS_FILE
from stair_lite.rendering import is_target, kept_compositing, kept_window_samples, live_rays


def timed(fn, repeats: int):
    """The median wall time of ``repeats`` calls and the last call's result."""
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def stored_mission(folder: Path, copy_to: Path) -> Mission:
    """The mission of a results folder restored from its checkpoint, from a copy (a running sweep holds the folder)."""
    for name in (METRICS_FILE, CHECKPOINT_FILE):
        shutil.copy(folder / name, copy_to / name)
    config = json.loads((folder / METRICS_FILE).read_text())["config"]
    config = {k: v for k, v in config.items() if k in MissionConfig.__dataclass_fields__}
    config["targets"] = tuple(config["targets"]) if config.get("targets") else None
    return Mission(MissionConfig(**config), out=copy_to, resume=True)


@torch.no_grad()
def share_behind_opaque(field, skip, kept_rays: torch.Tensor, kept_points: torch.Tensor, n_rays: int, targets,
                        transmittance_below: float = 1e-4) -> float:
    """The share of a view's kept samples (``kept_window_samples``) that lie behind the point where their ray's
    transmittance fell below ``transmittance_below``, in the target-only composite without the volume below
    ``GROUND_CUT_Z`` (its transmittance is never below the other composite's, so a sample behind that point is
    behind it in both)."""
    if len(kept_rays) == 0:
        return 0.0
    located = field.locate(kept_points)
    occ = field.occupancy_at(located) * is_target(field.appearance_at(located)[1], targets)
    lattice = skip.lattice
    occ = occ * (lattice.axis(occ.device)[lattice.nearest_layer(kept_points[:, 2])] >= GROUND_CUT_Z)
    places, ((_, transmittance),) = kept_compositing(kept_rays, n_rays, occ)
    return float((transmittance.view(-1)[places] < transmittance_below).float().mean())  # before each sample


def cut_schedule_field(preset, scene: str):
    """A field trained on three views with 60 iterations of 512 + 512 rays each, and its world."""
    world = World.build(scene, preset)
    implicit = build_map(IMPLICIT, preset, seed=0)
    trainer = implicit.trainer
    full = trainer.cfg
    trainer.cfg = replace(full, rays_new=512, rays_replay=512)
    for step, view in enumerate([np.array(TOP_VIEW)] + list(fibonacci_hemisphere(2, azimuth_offset=0.3)), start=1):
        implicit.add_measurement(world.measure(view, step))
        trainer.update(60)
    trainer.cfg = full
    return implicit, world.evaluator, world.targets


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--views", type=int, default=None, help="test views rendered (default: the preset's)")
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--scene", default="scene1")
    parser.add_argument("--mission", default=None, help="a mission's results folder with its checkpoint: time the "
                        "evaluation of its state (its preset and scene; --preset and --scene are ignored)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as copy_to:
        if args.mission:
            mission = stored_mission(Path(args.mission), Path(copy_to))
            implicit, evaluator, targets, preset = mission.map, mission.evaluator, mission.targets, mission.preset
            state = f"{args.mission} after {len(mission.records)} steps"
        else:
            preset = get_preset(args.preset)
            implicit, evaluator, targets = cut_schedule_field(preset, args.scene)
            state = f"{args.preset} preset, {args.scene}, a field after 3 views of a cut schedule"
        measure(args, preset, implicit, evaluator, targets, state)


def colour_forms(implicit, evaluator, poses, targets, repeats: int) -> tuple[float, float]:
    """Median render times of ``poses`` with the colour MLP as the evaluation runs it (in blocks) and in one pass over
    the whole batch (``mlp_on_parts``, its form before the blocks), the two alternated; the images must agree."""
    field = implicit.field

    def one_pass(f_rgb, pe):
        return torch.sigmoid(mlp_on_parts(field.rgb_mlp, f_rgb, pe))

    def render(colour_from=None):
        if colour_from is not None:
            field.colour_from = colour_from  # an instance attribute shadows the method for this render
        try:
            start = time.perf_counter()
            images = list(implicit.target_only_renders(evaluator.intrinsics, poses, targets, GROUND_CUT_Z))
            return time.perf_counter() - start, images
        finally:
            field.__dict__.pop("colour_from", None)

    times = {"blocks": [], "one pass": []}
    for _ in range(repeats):
        for name, form in (("blocks", None), ("one pass", one_pass)):
            seconds, images = render(form)
            times[name].append(seconds)
            if name == "blocks":
                blocked = images
            else:
                assert all(np.abs(a - b).max() <= 1e-6 for pair_a, pair_b in zip(blocked, images)
                           for a, b in zip(pair_a, pair_b))
    return statistics.median(times["blocks"]), statistics.median(times["one pass"])


def measure(args, preset, implicit, evaluator, targets, state: str):
    poses = evaluator.poses[: args.views or len(evaluator.poses)]
    implicit._target_skip = None
    t_skip, _ = timed(lambda: implicit.target_skip_grid(targets), 1)
    t_render, _ = timed(lambda: list(implicit.target_only_renders(evaluator.intrinsics, poses, targets, GROUND_CUT_Z)),
                        args.repeats)
    skip = implicit.target_skip_grid(targets)
    render_cfg = replace(implicit.trainer.render_cfg, n_samples=preset.eval.render_samples)
    sampled = [live_rays(skip, evaluator.intrinsics, [pose], render_cfg) for pose in poses[:5]]
    windows = [kept_window_samples(skip, *rays[1:], render_cfg.n_samples) for rays in sampled]
    kept = [points for _, points in windows]
    n_live = sum(len(rays[0]) for rays in sampled)
    field = implicit.field

    @torch.no_grad()
    def read_field():
        for points in kept:
            located = field.locate(points)
            field.occupancy_at(located), field.appearance_at(located)

    t_read, _ = timed(read_field, args.repeats)
    t_five, _ = timed(lambda: list(implicit.target_only_renders(evaluator.intrinsics, poses[:5], targets, GROUND_CUT_Z)),
                      args.repeats)
    behind = [share_behind_opaque(implicit.field, skip, ray, points, len(rays[0]), targets)
              for (ray, points), rays in zip(windows, sampled)]
    t_blocks, t_one_pass = colour_forms(implicit, evaluator, poses, targets, args.repeats)
    t_phantom, _ = timed(lambda: implicit.occupied_share_below(GROUND_CUT_Z), args.repeats)
    t_mesh, mesh = timed(lambda: implicit.target_mesh(targets), args.repeats)
    n, seed = preset.eval.mesh_points, evaluator.seed + 1
    t_sample, pred = timed(lambda: sample_surface(mesh, n, seed), args.repeats)
    cfg = preset.eval

    def default_scores():
        """The scores as scipy's default tree gives them, each side queried in the samples' own order."""
        d_pred, _ = cKDTree(evaluator.gt_points).query(pred, workers=-1)
        d_gt, _ = cKDTree(pred).query(evaluator.gt_points, workers=-1)
        return (d_pred.mean() + d_gt.mean()) / 2

    t_default, chamfer_default = timed(default_scores, args.repeats)
    t_ours, score = timed(lambda: mesh_scores_from_points(pred, evaluator.gt_tree, evaluator.gt_points, cfg.f1_threshold,
                                                          cfg.more_f1_thresholds, evaluator.gt_order), args.repeats)
    assert score.chamfer == chamfer_default  # the same nearest distances, summed in the same order
    print(f"{state} (F1 {score.f1:.3f}, chamfer {score.chamfer:.4f} m); medians over {args.repeats}, "
          f"{torch.get_num_threads()} torch threads:")
    print(f"  target skip grid                 {t_skip:7.2f} s (once per field state)")
    print(f"  target-only renders, {len(poses):3d} views     {t_render:7.2f} s ({cfg.image_scale:g} x 400 px, "
          f"{cfg.render_samples} samples per ray)")
    pixels = evaluator.intrinsics.height * evaluator.intrinsics.width
    print(f"    live rays per view {n_live / len(sampled):.0f} of {pixels}; per live ray "
          f"{sum(int((r[-1] - r[-2]).sum()) for r in sampled) / n_live:.1f} window samples, "
          f"{sum(len(k) for k in kept) / n_live:.1f} in kept cells")
    print(f"    reading the field at the kept samples of {len(kept)} views {t_read:.2f} s of their renders' {t_five:.2f} s")
    print(f"    kept samples behind the point where their ray is opaque (T < 1e-4): {min(behind):.1%} to "
          f"{max(behind):.1%} a view (the most that stopping rays once opaque could save)")
    print(f"    the colour MLP in blocks of 4096 rows (field.mlp_on_parts_in_blocks): renders {t_blocks:.2f} s against "
          f"{t_one_pass:.2f} s in one pass (alternated {args.repeats} times, the same images)")
    print(f"  phantom share (lattice below the ground) {t_phantom:5.2f} s (only the vertices a ray reached are queried)")
    print(f"  target mesh ({cfg.mesh_resolution}^3 lattice)       {t_mesh:7.2f} s")
    print(f"  surface samples ({n:.0e})         {t_sample:7.2f} s")
    print(f"  mesh scores, scipy's default tree {t_default:6.2f} s")
    print(f"  mesh scores, the evaluation's     {t_ours:6.2f} s  ({t_default / t_ours:.1f}x faster, the same scores)")
    total = t_skip + t_render * len(evaluator.poses) / len(poses) + t_phantom + t_mesh + t_sample + t_ours
    print(f"  one evaluation (renders scaled to all {len(evaluator.poses)} views): about {total:.0f} s")


if __name__ == "__main__":
    main()
