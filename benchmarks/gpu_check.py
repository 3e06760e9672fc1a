"""The GPU path, checked and timed on a CUDA machine (nothing here runs without one).

Run: .venv/bin/python benchmarks/gpu_check.py [--preset paper] [--steps 2]
1. runs the tests that need a GPU (``pytest tests -k gpu``);
2. runs the first ``--steps`` steps of a mission per map on the GPU, at the given preset: STAIR on the
   implicit map and STE on the explicit one, and prints each phase's wall time and the peak GPU memory.
Put the figures in the README when a GPU machine has run it.
"""
import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch

import stair_lite  # noqa: F401
from stair_lite.mission import Mission, MissionConfig

ROOT = Path(__file__).resolve().parent.parent


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--steps", type=int, default=2, help="mission steps per map (the first is the top view)")
    parser.add_argument("--skip-tests", action="store_true")
    args = parser.parse_args()
    if not torch.cuda.is_available():
        sys.exit(f"no CUDA GPU visible to torch {torch.__version__}: this check runs only on a GPU machine")
    print(f"GPU: {torch.cuda.get_device_name()}, torch {torch.__version__}, CUDA {torch.version.cuda}")
    if not args.skip_tests:
        tests = subprocess.run([sys.executable, "-m", "pytest", str(ROOT / "tests"), "-q", "-k", "gpu", "-rs"], cwd=ROOT)
        print(f"GPU tests: exit code {tests.returncode}")
    for planner in ("stair", "ste"):
        torch.cuda.reset_peak_memory_stats()
        start = time.perf_counter()
        mission = Mission(MissionConfig(planner=planner, preset=args.preset, budget=args.steps),
                          out=Path(tempfile.mkdtemp(prefix=f"gpu_{planner}_")), device="cuda")
        built = time.perf_counter() - start
        for record in mission.run():
            t = record["time_s"]
            print(f"{args.preset} {planner:5s} ({mission.config.mapper} map) step {record['step']}: plan {t['plan']:.2f} s, "
                  f"measure {t['measure']:.2f} s, train {t['train']:.2f} s, evaluate {t['evaluate']:.2f} s | "
                  f"PSNR {record['psnr']:.2f} dB, F1 {record['f1']:.3f}", flush=True)
        print(f"{args.preset} {planner}: mission built in {built:.1f} s (ground truth rendered); peak GPU memory "
              f"{torch.cuda.max_memory_allocated() / 2**30:.2f} GiB")


if __name__ == "__main__":
    main()
