"""Benchmark of the simulated world: time to render one 400x400 measurement (rgb, depth, labels).

Run: .venv/bin/python benchmarks/bench_world.py   (prints medians over several runs)
"""
import statistics
import time

import stair_lite  # noqa: F401  (sets the offscreen platform before pyrender loads)
from stair_lite.geometry import random_hemisphere, view_to_pose
from stair_lite.scenes import load_scene
from stair_lite.simulator import Simulator

import numpy as np


def main(repeats: int = 5, renders_per_repeat: int = 20):
    scene = load_scene("scene1")
    sim = Simulator(scene)
    poses = [view_to_pose(el, az) for el, az in random_hemisphere(renders_per_repeat, np.random.default_rng(0))]
    sim.render(poses[0])  # warm-up: shader compilation and upload
    medians = []
    for _ in range(repeats):
        times = []
        for pose in poses:
            start = time.perf_counter()
            sim.render(pose)
            times.append(time.perf_counter() - start)
        medians.append(statistics.median(times))
    print(f"scene1 ({sum(len(m.faces) for m in scene.object_meshes)} object faces), 400x400 rgb+depth+labels")
    print(f"render one measurement: median {1000 * statistics.median(medians):.1f} ms "
          f"(medians of {repeats} runs x {renders_per_repeat} renders: {', '.join(f'{1000 * m:.1f}' for m in medians)} ms)")


if __name__ == "__main__":
    main()
