"""Benchmark of the semantic field (issue targets): per-view update time, evaluation time, peak memory, and
the quality after the last of a fixed set of spread views, over several field seeds (the run-to-run spread).

Run: .venv/bin/python benchmarks/bench_field.py [--preset lite] [--views 10] [--scene scene1] [--seeds 3]
Measures, for the given preset, the incremental update after each new view (the preset's iterations per
view) and the target-only evaluation after the last views (PSNR over the test views plus mesh F1); prints
medians over the views, the quality after the last view per seed with its mean and standard deviation, and
the process's peak resident memory.
"""
import argparse
import resource
import statistics
import time

import stair_lite  # noqa: F401
from stair_lite.config import get_preset
from stair_lite.geometry import fibonacci_hemisphere
from stair_lite.maps import IMPLICIT
from stair_lite.mission import World, build_map

QUALITY = ("psnr", "psnr_clean", "f1", "f1_5cm", "phantom")


def run_seed(preset, world, args, seed, updates, evals):
    """Train one field (seeded) on the fixed views; returns the evaluation after the last view."""
    implicit = build_map(IMPLICIT, preset, seed=seed)
    for i, view in enumerate(fibonacci_hemisphere(args.views, azimuth_offset=0.3)):
        implicit.add_measurement(world.measure(view, i + 1))
        start = time.perf_counter()
        implicit.update()
        updates.append((i, time.perf_counter() - start))
        line = f"seed {seed} view {i + 1:2d}: update {updates[-1][1]:.2f} s"
        if i >= args.views - args.evals:
            start = time.perf_counter()
            result = world.evaluator.evaluate(implicit)
            evals.append(time.perf_counter() - start)
            line += (f" | evaluation {evals[-1]:.2f} s: PSNR {result['psnr']:.2f} dB (clean {result['psnr_clean']:.2f}), "
                     f"F1 {result['f1']:.3f} (5 cm {result['f1_5cm']:.3f}), phantom {result['phantom']:.3f}")
        print(line, flush=True)
    return result


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--preset", default="lite")
    parser.add_argument("--scene", default="scene1")
    parser.add_argument("--views", type=int, default=10)
    parser.add_argument("--evals", type=int, default=3, help="evaluate after this many of the last views")
    parser.add_argument("--seeds", type=int, default=3, help="field seeds 0..n-1: the run-to-run spread of the quality")
    args = parser.parse_args()
    preset = get_preset(args.preset)
    world = World.build(args.scene, preset)
    updates, evals, finals = [], [], []
    for seed in range(args.seeds):
        finals.append(run_seed(preset, world, args, seed, updates, evals))
    peak_gb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
    later = [t for i, t in updates if i > 0]
    print(f"preset {preset.name}: {preset.train.iterations_per_view} iterations/view, "
          f"{preset.train.rays_new}+{preset.train.rays_replay} rays, grid {preset.field.grid_resolution}^3")
    print(f"update after one new view: median {statistics.median(t for _, t in updates):.2f} s (views 2-{args.views}: "
          f"median {statistics.median(later):.2f} s, max {max(later):.2f} s)")
    print(f"one target-only evaluation ({preset.eval.n_test_views} test views + mesh F1): median {statistics.median(evals):.2f} s")
    for key in QUALITY:
        values = [f[key] for f in finals]
        spread = statistics.stdev(values) if len(values) > 1 else float("nan")
        print(f"after view {args.views}, {key}: mean {statistics.mean(values):.3f}, sd {spread:.3f} over {len(values)} seeds "
              f"({', '.join(f'{v:.3f}' for v in values)})")
    print(f"peak resident memory: {peak_gb:.2f} GB")


if __name__ == "__main__":
    main()
