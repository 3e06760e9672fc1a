"""Command line: ``python -m stair_lite <command>``; ``--help`` on each command lists its options.

  scenes   list the shipped scenes
  render   render a scene from a few views into a figure (the simulated world)
  fit      fit a field to fixed views of a scene and report target-only PSNR and mesh F1
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import stair_lite  # noqa: F401  (sets the offscreen platform before pyrender loads)


def _cmd_scenes(args):
    from .classes import CLASS_NAMES
    from .scenes import list_scenes, load_scene_spec

    for name in list_scenes():
        spec = load_scene_spec(name)
        classes = sorted({CLASS_NAMES[o.cls] for o in spec.objects})
        print(f"{name:22s} targets: {', '.join(CLASS_NAMES[t] for t in spec.targets):16s} "
              f"{len(spec.objects)} objects ({', '.join(classes)})")


def _cmd_render(args):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from .plotting import show_measurement
    from .scenes import load_scene
    from .simulator import Simulator

    sim = Simulator(load_scene(args.scene))
    views = [(np.pi / 2, 0.0), (0.6, 0.5), (0.25, 2.5)]
    fig, axes = plt.subplots(len(views), 3, figsize=(11, 3.6 * len(views)))
    for row, (el, az) in zip(axes, views):
        show_measurement(sim.render_view(el, az), f"el {np.degrees(el):.0f} az {np.degrees(az):.0f}", axes=row)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out / f"{args.scene}_views.png", dpi=80)
    print(f"wrote {out / f'{args.scene}_views.png'}")


def _cmd_fit(args):
    from dataclasses import replace

    import numpy as np

    from .config import get_preset
    from .evaluation import Evaluator
    from .field import SemanticField
    from .geometry import fibonacci_hemisphere, view_to_pose
    from .scenes import load_scene
    from .simulator import Simulator
    from .training import Trainer

    preset = get_preset(args.preset)
    if args.iterations is not None:
        preset = replace(preset, train=replace(preset.train, iterations_per_view=args.iterations))
    if args.rays is not None:
        preset = replace(preset, train=replace(preset.train, rays_new=args.rays, rays_replay=args.rays))
    if args.views < 1:
        raise SystemExit(f"--views must be at least 1, got {args.views}")
    scene = load_scene(args.scene)
    targets = scene.check_targets(args.targets.split(",") if args.targets else scene.targets)
    sim = Simulator(scene)
    field = SemanticField(preset.field, seed=args.seed)
    trainer = Trainer(field, preset.train, preset.render, seed=args.seed)
    evaluator = Evaluator(sim, targets, preset, seed=args.seed)
    views = fibonacci_hemisphere(args.views, azimuth_offset=0.3)
    print(f"preset {preset.name}: grid {preset.field.grid_resolution}^3, {preset.train.iterations_per_view} "
          f"iterations/view, {preset.train.rays_new}+{preset.train.rays_replay} rays; scene {scene.name}, targets {targets}")
    start = time.perf_counter()
    for i, (el, az) in enumerate(views):
        trainer.add_measurement(sim.render(view_to_pose(el, az)))
        history = trainer.update()
        print(f"view {i + 1:2d}/{len(views)} (el {np.degrees(el):4.1f}, az {np.degrees(az):5.1f}): "
              f"loss {history[-1].total:.4f}", flush=True)
    t_train = time.perf_counter() - start
    result = evaluator.evaluate(field)
    print(f"target-only PSNR {result['psnr']:.2f} dB over {len(evaluator.poses)} test views | mesh precision "
          f"{result['precision']:.3f} completeness {result['completeness']:.3f} F1 {result['f1']:.3f} "
          f"(1 cm, {preset.eval.mesh_points} points) | training {t_train:.1f} s, evaluation {result['time_total_s']:.1f} s")
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        if result["mesh"] is not None:
            result["mesh"].export(out / "target_mesh.ply")
            print(f"wrote {out / 'target_mesh.ply'}")


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m stair_lite", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("scenes", help="list the shipped scenes").set_defaults(func=_cmd_scenes)
    p = sub.add_parser("render", help="render a scene from a few views")
    p.add_argument("--scene", default="scene1")
    p.add_argument("--out", default="runs/render")
    p.set_defaults(func=_cmd_render)
    p = sub.add_parser("fit", help="fit a field to fixed spread views and evaluate it")
    p.add_argument("--scene", default="scene1")
    p.add_argument("--preset", default="lite", choices=["lite", "paper"])
    p.add_argument("--views", type=int, default=10)
    p.add_argument("--targets", default=None, help="comma-separated class names (default: the scene's)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--iterations", type=int, default=None, help="override iterations per view")
    p.add_argument("--rays", type=int, default=None, help="override new and replay rays per iteration")
    p.add_argument("--out", default=None, help="folder for the target mesh (PLY)")
    p.set_defaults(func=_cmd_fit)
    args = parser.parse_args(argv)
    try:
        args.func(args)
    except (ValueError, FileNotFoundError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
