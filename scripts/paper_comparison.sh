#!/usr/bin/env bash
# The paper-scale comparison (RESULTS.md, "At the paper's scale"): the four paper scenes x STAIR, Exploration, the
# fixed spiral, Max View Distance and STE at the paper preset (128^3 field and voxel map, 8000 rays and 200
# iterations per view, the paper's evaluation after every step), seed by seed, so a sweep stopped early holds whole
# seeds. Within a seed, WORKERS lanes run side by side, each one mission at a time on one torch thread (as a sweep's
# workers), the scenes dealt out among them and each lane finishing a scene's five variants before its next scene:
# whole scenes land early (`python -m stair_lite scale-claims` reads every scene with all five finished).
# Resumable: run it again to continue; finished cells stay. On this 2-core CPU a mission of an implicit planner takes
# 18-63 minutes (STE 4-30): start it when nothing is being measured, and commit the finished cells as they land. Ctrl-C
# in the terminal stops every lane (they share its process group); an unfinished mission resumes from its last finished
# step.
#   bash scripts/paper_comparison.sh [SEEDS] [WORKERS] [DEVICE] [OUT]
#   (default: 3 seeds, 2 workers, cpu, the stored study's folder data/results/comparison_paper; a run on another
#   device goes to a folder of its own, e.g. runs/gpu/comparison_paper: the stored study's finished cells are kept, not run again)
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=${1:-3}
workers=${2:-2}
device=${3:-cpu}
out=${4:-data/results/comparison_paper}
PY=${PY:-.venv/bin/python}
scenes=(scene1 scene2 scene3 scene4)
for seed in $(seq 0 $((seeds - 1))); do
  lanes=()
  for lane in $(seq 0 $((workers - 1))); do
    (
      for i in "${!scenes[@]}"; do
        if (( i % workers == lane )); then
          "$PY" -m stair_lite sweep --scenes "${scenes[$i]}" --planners stair,exploration,fixed,max_distance,ste \
            --first-seed "$seed" --seeds 1 --workers 1 --preset paper --device "$device" --quiet \
            --out "$out"
        fi
      done
    ) &
    lanes+=($!)
  done
  for pid in "${lanes[@]}"; do
    wait "$pid"
  done
done
