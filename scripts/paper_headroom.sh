#!/usr/bin/env bash
# The paper-scale headroom tables (RESULTS.md, "At the paper's scale"): scene1 and scene4 after K = 3 views of a
# seeded STAIR mission at the paper preset, 16 spread next views each realised with three training streams, and every
# registered utility's pick (the lite league's standard set, at this scale). Two lanes side by side, one scene each, on
# one torch thread each. Resumable: each table keeps its realised views in <table>.partial.jsonl until it is saved.
# About two hours of one core per table on this 2-core CPU; never beside a benchmark.
#   bash scripts/paper_headroom.sh [DEVICE] [OUT]     (default: cpu, the stored tables' folder
#   data/results/headroom_league_paper; a run on another device goes to a folder of its own); then:
#   python -m stair_lite league --results OUT
set -euo pipefail
cd "$(dirname "$0")/.."
device=${1:-cpu}
out=${2:-data/results/headroom_league_paper}
PY=${PY:-.venv/bin/python}
lanes=()
for scene in scene1 scene4; do
  OMP_NUM_THREADS=1 "$PY" -m stair_lite headroom --preset paper --scene "$scene" --after 3 --candidates 16 --streams 3 \
    --device "$device" --quiet --out "$out" &
  lanes+=($!)
done
for pid in "${lanes[@]}"; do
  wait "$pid"
done
