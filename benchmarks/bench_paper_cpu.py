"""The paper preset on this CPU, in the units of the speed issue's table: one training iteration
(4000 newest + 4000 replayed rays, 128^3 grids), one candidate render for planning (80 x 80 rays x 200
samples, from the field snapshot), one planning step (the two-stage search over 200 candidates), and
the process's peak memory. With ``--evaluate``, also the paper's evaluation of the field and one whole mission step
(planning, the preset's iterations, evaluation) against the authors' step without any evaluation.

The authors' step: their code (dmar-bonn/stair, unmodified, at 2 torch threads, measured with
``benchmarks/authors_step.py`` on our scene 1's top view and a second view) trains 200 iterations of their 8000-ray
batch (4000 new + 4000 replayed rays, from their second view on) and scores 200 candidates in their planner's two
batched calls of 100 (80 x 80 rays, 440 samples per ray), before the mesh and model their loop saves after every step.
The ratio divides by that step as measured on this machine's CPU (``authors_step.py`` stores it, with the CPU's name, in
runs/authors/step.json); without such a record, by the constants below, measured on an AMD EPYC (and it says so): a
ratio across two CPUs is not the target's.

Run: .venv/bin/python benchmarks/bench_paper_cpu.py [--repeats 3] [--planning-steps 1] [--evaluate]
     .venv/bin/python benchmarks/bench_paper_cpu.py --mission [--budget 10] [--iterations 200]
With ``--mission``: instead, one whole paper-preset STAIR mission (planning, training and the paper's
evaluation after every step: 100 test views at 400x400, a 256^3 mesh lattice, 1e6 points per mesh), each step's
phases, and its peak memory; with the preset's 200 iterations per view (the default), each step and the mean step
against the authors' step. A cut schedule (``--iterations 5``) measures the memory, not the time (the batch is the
paper's).
     .venv/bin/python benchmarks/bench_paper_cpu.py --work FOLDER [--repeats 2]
With ``--work``: instead, the work of one step on a stored paper mission's state (FOLDER: a mission's results folder
with its checkpoint, copied first; the stored one is not changed): 40 training iterations on its newest view, one
planning step and one evaluation, each at this machine's cores' count of torch threads and at one thread, alternated
(medians of ``--repeats`` each). At one thread a phase's wall time is its work; a step's work divided by the cores
is the shortest step that any schedule of the phases on this CPU could reach (the evaluation beside the next step's
training, say), to set beside a fifth of the authors' step.
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import tempfile
import time
from dataclasses import replace

import numpy as np
import torch

import stair_lite  # noqa: F401
from stair_lite.config import get_preset
from stair_lite.geometry import TOP_VIEW, Intrinsics, fibonacci_hemisphere
from stair_lite.maps import IMPLICIT
from stair_lite.mission import Mission, MissionConfig, World, build_map
from stair_lite.planners import make_planner
from stair_lite.results_folder import CHECKPOINT_FILE, METRICS_FILE
from stair_lite.utility import FieldSnapshot, score_views

from authors_record import RECORD_DEFAULT, cpu_model, read_record

# the authors' code (dmar-bonn/stair, unmodified) measured on an AMD EPYC at 2 threads (benchmarks/authors_step.py,
# 2026-12-07): seconds per 8000-ray training iteration and per candidate in their planner's batched calls; a step trains
# 200 iterations and scores 200 candidates. Used only where no record of this machine's CPU exists
AUTHORS_ITERATION_S, AUTHORS_CANDIDATE_S = 0.964, 0.364
AUTHORS_ITERATIONS, AUTHORS_CANDIDATES = 200, 200  # their iteration_per_step and num_candidates
AUTHORS_STEP_S = AUTHORS_ITERATIONS * AUTHORS_ITERATION_S + AUTHORS_CANDIDATES * AUTHORS_CANDIDATE_S
AUTHORS_STEP_CPU = "AMD EPYC"


def authors_step(record_path: str = RECORD_DEFAULT) -> tuple[float, str]:
    """The authors' step without evaluation [s] and where it was measured: this CPU's record, else the constants."""
    record = read_record(record_path)
    if record is not None:
        return record["step_s"], f"measured on this CPU ({record['cpu']}, {record['threads']} threads; {record_path})"
    return AUTHORS_STEP_S, (f"measured on an {AUTHORS_STEP_CPU}, not on this CPU ({cpu_model()}): run "
                            f"benchmarks/authors_step.py --views 2 here for the target's ratio")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=3, help="timed runs of skip_refresh training iterations")
    parser.add_argument("--planning-steps", type=int, default=1)
    parser.add_argument("--scene", default="scene1")
    parser.add_argument("--mission", action="store_true", help="instead, one whole mission: each step's phases, the mean "
                        "step against the authors' step, the peak memory")
    parser.add_argument("--evaluate", action="store_true", help="also the paper's evaluation and a whole mission step")
    parser.add_argument("--budget", type=int, default=10, help="(--mission) measurements")
    parser.add_argument("--iterations", type=int, default=None, help="(--mission) training iterations per view "
                        "(default: the preset's)")
    parser.add_argument("--work", metavar="FOLDER", help="instead, a step's work at one thread and at all cores, on a "
                        "stored paper mission's state")
    args = parser.parse_args()
    preset = get_preset("paper")
    if args.mission:
        return whole_mission(preset, args.scene, args.budget, args.iterations)
    if args.work:
        return step_work(args.work, args.repeats)
    world = World.build(args.scene, preset)
    scene = world.scene
    implicit = build_map(IMPLICIT, preset, seed=0)
    trainer, tc = implicit.trainer, preset.train
    visited = [np.array(TOP_VIEW)] + list(fibonacci_hemisphere(2, azimuth_offset=0.3))
    for step, view in enumerate(visited, start=1):  # three views, so that replay rays exist
        implicit.add_measurement(world.measure(view, step))
        trainer.update(1)
    label = (f"one training iteration ({tc.rays_new} + {tc.rays_replay} rays, {preset.field.grid_resolution}^3 grids, "
             f"{preset.render.n_samples} samples per ray; time of {tc.skip_refresh} iterations, one skip-grid build "
             f"included, / {tc.skip_refresh})")
    start = time.perf_counter()
    trainer.update(tc.skip_refresh)
    print(f"paper preset, {label}, fresh field (no cell skippable): {(time.perf_counter() - start) / tc.skip_refresh:.2f} s")
    # a field that has learnt the free space of its three views (a cut schedule: 40 iterations of 512 + 512 rays
    # per view), as a field is after its first views in a mission
    trainer.cfg = replace(tc, rays_new=512, rays_replay=512)
    for _ in visited:
        trainer.update(40)
    trainer.cfg = tc
    times = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        trainer.update(tc.skip_refresh)
        times.append((time.perf_counter() - start) / tc.skip_refresh)
    print(f"paper preset, {label}, field trained on 3 views: median {statistics.median(times):.2f} s over "
          f"{args.repeats} (min {min(times):.2f}, max {max(times):.2f}); the skip grid keeps "
          f"{trainer.skip.keep.float().mean():.0%} of the cells")
    peak_after_training = peak_gb()
    p = preset.plan
    k = Intrinsics.from_fov().scaled(p.candidate_scale)
    start = time.perf_counter()
    snapshot = FieldSnapshot(implicit.field)
    t_snapshot = time.perf_counter() - start
    views = fibonacci_hemisphere(10, azimuth_offset=0.1)
    renders = []
    for view in views:
        start = time.perf_counter()
        score_views(snapshot, view[None], scene.targets, k, p.candidate_samples)
        renders.append(time.perf_counter() - start)
    print(f"one candidate render ({k.width}x{k.height} rays x {p.candidate_samples} samples, from the snapshot): median "
          f"{statistics.median(renders):.3f} s over {len(views)} views (snapshot of {snapshot.lattice.resolution}^3 "
          f"vertices: {t_snapshot:.2f} s)")
    planner = make_planner("stair", preset, seed=0)
    steps = []
    for _ in range(args.planning_steps):
        start = time.perf_counter()
        decision = planner.next_view(implicit.field, np.array(visited), scene.targets)
        steps.append(time.perf_counter() - start)
    if steps:
        print(f"one planning step ({len(decision.candidates)} candidates): median {statistics.median(steps):.1f} s "
              f"over {args.planning_steps}")
    if args.evaluate and steps:
        start = time.perf_counter()
        result = world.evaluator.evaluate(implicit)
        t_eval = time.perf_counter() - start
        iteration = statistics.median(times)
        step = statistics.median(steps) + tc.iterations_per_view * iteration + t_eval
        print(f"the paper's evaluation of this field (PSNR {result['psnr']:.2f} dB, F1 {result['f1']:.3f}): {t_eval:.1f} s")
        theirs, where = authors_step()
        print(f"one mission step: planning {statistics.median(steps):.1f} s + {tc.iterations_per_view} iterations x "
              f"{iteration:.2f} s + evaluation {t_eval:.1f} s = {step:.0f} s; the authors' step without evaluation "
              f"{theirs:.0f} s ({where}): {step / theirs:.2f} of it (target 0.2)")
    print(f"peak resident memory: {peak_gb():.2f} GB (after training: {peak_after_training:.2f} GB)")


def whole_mission(preset, scene: str, budget: int, iterations: int | None) -> None:
    """One STAIR mission of ``budget`` views at the paper preset (``iterations`` per view, default the preset's): each
    step's phases, the mean step against the authors' step (at the preset's schedule), and the peak memory."""
    if iterations is not None:
        preset = replace(preset, train=replace(preset.train, iterations_per_view=iterations))
    full_schedule = preset.train.iterations_per_view == get_preset("paper").train.iterations_per_view
    steps = []

    def report(record):
        t = record["time_s"]
        steps.append(t["plan"] + t["measure"] + t["train"] + t["evaluate"])
        print(f"step {record['step']}: plan {t['plan']:.1f} s, train {t['train']:.1f} s, evaluate {t['evaluate']:.1f} s"
              f" = {steps[-1]:.0f} s; peak so far {peak_gb():.2f} GB; F1 {record['f1']:.3f}", flush=True)

    mission = Mission(MissionConfig(scene=scene, planner="stair", seed=0, preset="paper", budget=budget), preset=preset)
    mission.run(on_step=report)
    print(f"one paper-preset mission of {budget} views ({preset.train.iterations_per_view} iterations per view), "
          f"evaluation after every step: peak resident memory {peak_gb():.2f} GB")
    if full_schedule:
        mean = statistics.mean(steps)
        theirs, where = authors_step()
        print(f"mean step {mean:.1f} s (median {statistics.median(steps):.1f} s); the authors' step without evaluation "
              f"{theirs:.0f} s ({where}): {mean / theirs:.3f} of it (target 0.2)")


def step_work(folder: str, repeats: int, iterations: int = 40) -> None:
    """Each phase of a step on the stored state of ``folder``, at all cores and at one torch thread, alternated; the
    step's work at one thread (the preset's iterations scaled from ``iterations``) over the cores: a floor for any
    schedule of the phases on this CPU."""
    missing = [name for name in (METRICS_FILE, CHECKPOINT_FILE) if not os.path.isfile(os.path.join(folder, name))]
    if missing:
        raise SystemExit(f"{folder} has no {' or '.join(missing)}: --work takes a stored mission's folder with its "
                         f"checkpoint (checkpoints stay on the machine that ran the mission)")
    config = json.load(open(os.path.join(folder, METRICS_FILE)))["config"]
    if config["preset"] != "paper":
        raise SystemExit(f"{folder} holds a {config['preset']!r} mission; --work takes a paper one")
    cores = os.cpu_count()
    phases: dict[tuple[str, int], list[float]] = {}
    with tempfile.TemporaryDirectory() as scratch:
        for _ in range(repeats):
            for threads in (cores, 1):
                copy = shutil.copytree(folder, os.path.join(scratch, "state"), dirs_exist_ok=True)
                torch.set_num_threads(threads)
                mission = Mission(MissionConfig(scene=config["scene"], planner=config["planner"], seed=config["seed"],
                                                preset="paper", budget=config["budget"]), out=copy, resume=True)
                mission.release()
                for name, phase in (
                        ("train", lambda: mission.map.trainer.update(iterations)),
                        ("plan", mission.plan),
                        ("evaluate", lambda: mission.evaluator.evaluate(mission.map))):
                    start = time.perf_counter()
                    phase()
                    phases.setdefault((name, threads), []).append(time.perf_counter() - start)
    median = {key: statistics.median(times) for key, times in phases.items()}
    per_view = get_preset("paper").train.iterations_per_view
    print(f"a step's phases on the state of {folder} ({len(mission.records)} views), medians of {repeats}:")
    for name in ("train", "plan", "evaluate"):
        print(f"  {name}{f' ({iterations} iterations)' if name == 'train' else ''}: {median[name, cores]:.1f} s at "
              f"{cores} threads, {median[name, 1]:.1f} s at one ({median[name, 1] / median[name, cores]:.2f}x)")
    def step(threads):
        return median["train", threads] * per_view / iterations + median["plan", threads] + median["evaluate", threads]
    theirs, where = authors_step()
    print(f"a step ({per_view} iterations): {step(cores):.1f} s at {cores} threads; its work at one thread "
          f"{step(1):.1f} core-seconds, so no schedule on {cores} cores takes under {step(1) / cores:.1f} s; a fifth of "
          f"the authors' step is {theirs / 5:.1f} s ({where})")


def peak_gb() -> float:
    """The process's peak resident memory so far, in GB (10**9 bytes; Linux reports kibibytes)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e9


if __name__ == "__main__":
    main()
