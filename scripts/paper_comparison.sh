#!/usr/bin/env bash
# The paper-scale comparison (RESULTS.md, "At the paper's scale"): the four paper scenes x STAIR, Exploration, the
# fixed spiral, Max View Distance and STE at the paper preset (128^3 field and voxel map, 8000 rays and 200
# iterations per view, the paper's evaluation after every step), seed by seed, so a sweep stopped early holds whole
# seeds. Resumable: run it again to continue; finished cells stay. On this 2-core CPU a mission takes tens of minutes:
# start it when nothing is being measured, and commit the finished cells as they land.
#   bash scripts/paper_comparison.sh [SEEDS] [WORKERS] [DEVICE]     (default: 3 seeds, 2 workers, cpu)
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=${1:-3}
workers=${2:-2}
device=${3:-cpu}
PY=${PY:-.venv/bin/python}
for seed in $(seq 0 $((seeds - 1))); do
  "$PY" -m stair_lite sweep --scenes all --planners stair,exploration,fixed,max_distance,ste --first-seed "$seed" \
    --seeds 1 --workers "$workers" --preset paper --device "$device" --quiet --out data/results/comparison_paper
done
