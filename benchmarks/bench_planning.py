"""Benchmark of view planning and of a whole mission (lite preset by default).

Run: .venv/bin/python benchmarks/bench_planning.py [--preset lite] [--repeats 5] [--mission] [--iterations N] [--sets 4]
Prints: the median time of one STAIR planning step and of one STE planning step (all N_uni + K * N_re candidate renders, from the
field snapshot), how often the snapshot picks the same view as the exact field (every sample through
the MLPs) on the same candidates, the exact-utility regret when it does not, and (with --mission) the
wall time of one full 10-measurement STAIR mission with evaluation after every step.
"""
import argparse
import statistics
import time

import numpy as np

import stair_lite  # noqa: F401
from stair_lite.config import get_preset
from stair_lite.geometry import TOP_VIEW, Intrinsics, fibonacci_hemisphere
from stair_lite.maps import EXPLICIT, IMPLICIT
from stair_lite.mission import Mission, MissionConfig, World, build_map
from stair_lite.planners import make_planner
from stair_lite.utility import FieldSnapshot, UtilityOptions, score_views


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--preset", default="lite")
    parser.add_argument("--scene", default="scene1")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--mission", action="store_true", help="also time one full STAIR mission")
    parser.add_argument("--sets", type=int, default=4, help="candidate sets on which the snapshot meets the exact field")
    parser.add_argument("--iterations", type=int, default=None,
                        help="training iterations per view of the field planned on (default: the preset's; a cut "
                             "schedule makes the paper preset affordable on a CPU)")
    args = parser.parse_args()
    preset = get_preset(args.preset)
    world = World.build(args.scene, preset)
    scene = world.scene
    implicit = build_map(IMPLICIT, preset, seed=0)
    field = implicit.field
    visited = [np.array(TOP_VIEW)] + list(fibonacci_hemisphere(3, azimuth_offset=0.3))
    for step, view in enumerate(visited, start=1):
        implicit.add_measurement(world.measure(view, step))
        implicit.trainer.update(args.iterations)
    planner = make_planner("stair", preset, seed=0)
    times = []
    for _ in range(args.repeats + 1):
        start = time.perf_counter()
        decision = planner.next_view(field, np.array(visited), scene.targets)
        times.append(time.perf_counter() - start)
    n = len(decision.candidates)
    p = preset.plan
    print(f"preset {preset.name}: {n} candidates, {round(400 * p.candidate_scale)}^2 rays x {p.candidate_samples} samples each")
    print(f"one planning step: median {statistics.median(times[1:]):.2f} s over {args.repeats} runs "
          f"({', '.join(f'{t:.2f}' for t in times[1:])}; first run {times[0]:.2f} s)")

    # Snapshot vs exact, on the same candidate sets (uniform stage of several planning steps).
    k = Intrinsics.from_fov().scaled(p.candidate_scale)
    options = UtilityOptions(epsilon=p.epsilon)
    same, regrets = 0, []
    rng = np.random.default_rng(1)
    trials = args.sets
    for _ in range(trials):
        candidates = fibonacci_hemisphere(p.n_uniform, azimuth_offset=rng.uniform(0, 2 * np.pi))
        fast = score_views(FieldSnapshot(field), candidates, scene.targets, k, p.candidate_samples, options).utility
        exact = score_views(field, candidates, scene.targets, k, p.candidate_samples, options).utility
        same += int(np.argmax(fast) == np.argmax(exact))
        regrets.append(1.0 - exact[np.argmax(fast)] / exact.max())
    print(f"snapshot vs exact field on {trials} sets of {p.n_uniform} candidates: same choice {same}/{trials}, "
          f"exact utility of the snapshot's choice within {100 * max(regrets):.1f} % of the best "
          f"(median {100 * statistics.median(regrets):.1f} %), rank correlation "
          f"{np.corrcoef(np.argsort(np.argsort(fast)), np.argsort(np.argsort(exact)))[0, 1]:.3f} (last set)")

    # The explicit STE baseline: its map integrates the same views, then one ROI planning step.
    emap = build_map(EXPLICIT, preset)
    measurements = [world.measure(view, step) for step, view in enumerate(visited, start=1)]
    start = time.perf_counter()
    for m in measurements:
        emap.integrate(m)
    t_integrate = (time.perf_counter() - start) / len(visited)
    ste = make_planner("ste", preset, seed=0)
    ste_times = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        ste.next_view(emap, np.array(visited), scene.targets)
        ste_times.append(time.perf_counter() - start)
    print(f"STE ({preset.explicit.resolution}^3 voxels): integrate one view {t_integrate:.2f} s; one planning step "
          f"({preset.explicit.n_candidates} candidates): median {statistics.median(ste_times):.2f} s over {args.repeats} runs")

    if args.mission:
        start = time.perf_counter()
        records = Mission(MissionConfig(scene=args.scene, planner="stair", seed=0, preset=args.preset)).run()
        total = time.perf_counter() - start
        phases = {k: sum(r["time_s"][k] for r in records) for k in records[0]["time_s"]}
        print(f"one {len(records)}-measurement STAIR mission with evaluation after every step: {total:.1f} s "
              f"({', '.join(f'{k} {v:.1f} s' for k, v in phases.items())}); final PSNR {records[-1]['psnr']:.2f} dB, "
              f"F1 {records[-1]['f1']:.3f}")


if __name__ == "__main__":
    main()
