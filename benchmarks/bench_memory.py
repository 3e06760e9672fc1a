"""Benchmark of a long mission's memory: a smoke-preset mission of many views (default 300) that follows a
fixed list of views (the replay planner, so no planner runs out of far-enough candidates), with training
and evaluation after every step.

Run: .venv/bin/python benchmarks/bench_memory.py [--views 300] [--every 50]
Prints, every ``--every`` views: the process's resident memory, the ray buffer's bytes, the megabytes
added per view since the last line, and the mean wall time of a step since then. Memory that grows
linearly shows as a constant MB per view; the ray buffer holds ``RayBuffer.BYTES_PER_RAY`` bytes per ray.
"""
import argparse
import json
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

import stair_lite  # noqa: F401
from stair_lite.geometry import TOP_VIEW, fibonacci_hemisphere
from stair_lite.mission import Mission, MissionConfig
from stair_lite.training import RayBuffer


def resident_mb() -> float:
    """The process's current resident memory [MB] (Linux)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * resource.getpagesize() / 2**20


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--views", type=int, default=300)
    parser.add_argument("--every", type=int, default=50)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="bench_memory_"))
    views = np.vstack([TOP_VIEW, fibonacci_hemisphere(args.views - 1, azimuth_offset=0.3)])
    (folder / "views.json").write_text(json.dumps({"steps": [{"view_rad": v.tolist()} for v in views]}))
    config = MissionConfig(planner="replay", replay=str(folder / "views.json"), preset="smoke", budget=args.views)
    mission = Mission(config, out=folder / "mission")
    buffer = mission.map.trainer.buffer
    print(f"smoke mission of {args.views} views (400x400 rays each, {RayBuffer.BYTES_PER_RAY} bytes per ray in the buffer: "
          f"{RayBuffer.BYTES_PER_RAY * 400 * 400 / 2**20:.1f} MB per view)")
    print(f"{'views':>6} {'RSS MB':>8} {'buffer MB':>10} {'MB/view since last':>19} {'s/step since last':>18}")
    last_views, last_rss, last_time = 0, resident_mb(), time.perf_counter()
    per_view = []
    while not mission.finished:
        mission.step()
        n = len(mission.records)
        if n % args.every == 0 or mission.finished:
            rss, now = resident_mb(), time.perf_counter()
            per_view.append((rss - last_rss) / (n - last_views))
            print(f"{n:6d} {rss:8.0f} {buffer.nbytes / 2**20:10.0f} {per_view[-1]:19.1f} {(now - last_time) / (n - last_views):18.2f}",
                  flush=True)
            last_views, last_rss, last_time = n, rss, now
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    later = per_view[1:] or per_view
    print(f"peak resident memory {peak:.0f} MB; MB per view after the first {args.every} views: "
          f"{np.mean(later):.1f} (min {min(later):.1f}, max {max(later):.1f})")


if __name__ == "__main__":
    main()
