#!/usr/bin/env bash
# The label-noise study (notebook 07, RESULTS.md "When the labels lie"): the four paper scenes at the lite
# preset, label noise none, low and high, seed by seed, so a sweep stopped early holds whole seeds.
# Level none's stair, exploration and max_distance missions are the same missions as comparison_<preset>'s
# (exact labels), so that folder serves them. Resumable: run it again to continue; finished cells stay.
#   bash scripts/label_noise_sweep.sh [SEEDS] [WORKERS] [PRESET]     (default: 8 seeds, 2 workers, lite)
set -euo pipefail
cd "$(dirname "$0")/.."
seeds=${1:-8}
workers=${2:-2}
preset=${3:-lite}
PY=${PY:-.venv/bin/python}
sweep() {  # level, planners, seed
  "$PY" -m stair_lite sweep --scenes all --label-noise "$1" --planners "$2" --first-seed "$3" --seeds 1 \
    --workers "$workers" --preset "$preset" --quiet --out "data/results/label_noise_$1_$preset"
}
# first the question the study asks (does semantic uncertainty help?), then the other variants
for seed in $(seq 0 $((seeds - 1))); do
  sweep none stair_semantic "$seed"
  sweep low stair,stair_semantic "$seed"
  sweep high stair,stair_semantic "$seed"
done
for seed in $(seq 0 $((seeds - 1))); do
  sweep none stair_soft "$seed"
  sweep low stair_soft,exploration,max_distance "$seed"
  sweep high stair_soft,exploration,max_distance "$seed"
done
