#!/usr/bin/env bash
# The searches behind the shipped `general` preset (studies/history.md#tuning-per-grid-size): the
# general weights on the held-out generated set 'tune', one Optuna study per method and planning-grid
# size, the same budget for every study, each starting from the method's `tuned` constants (trial 1;
# trial 0 is the spec point), then the preset with one entry per grid size and its check on fresh seeds.
#
#   tools/tune_general.sh                    # QL, O-QL, IQL, NDR-QL at grids 50 and 100; then presets/general.json
#   GRIDS=50 METHODS="IQL NDR-QL" SKIP_EXPORT=1 tools/tune_general.sh   # some studies, no preset yet
#
# Resumable: run it again after any interruption and each study continues where it stopped.
# Studies live in results/tune/studies.db (outside git).
set -euo pipefail
cd "$(dirname "$0")/.."
NDRQL=${NDRQL:-.venv/bin/ndrql}
METHODS=${METHODS:-NDR-QL IQL QL O-QL}
START_FROM=${START_FROM:-tuned}
GRIDS=${GRIDS:-50 100}
TRIALS=${TRIALS:-250}
SAMPLES=${SAMPLES:-120}
SEEDS=${SEEDS:-5}
WORKERS=${WORKERS:-2}
MAX_EPISODES=${MAX_EPISODES:-6000}
PRESET=${PRESET:-src/ndrql/planning/presets/general.json}
budget=(--maps generated --weights general --trials "$TRIALS" --samples "$SAMPLES" --seeds "$SEEDS"
        --max-episodes "$MAX_EPISODES" --workers "$WORKERS" --start-from "$START_FROM" --out results/tune)

for n in $GRIDS; do
  for m in $METHODS; do
    echo "$(date -u +%FT%TZ) tune $m at grid $n" >&2
    nice -n 5 "$NDRQL" tune --method "$m" --grid "$n" "${budget[@]}" --no-progress
  done
done
[ -n "${SKIP_EXPORT:-}" ] && exit 0
list=$(echo "${EXPORT_METHODS:-$METHODS}" | tr ' ' ',')
grids=$(echo "$GRIDS" | tr ' ' ',')
NDRQL_WRITE_PACKAGE=1 nice -n 5 "$NDRQL" tune --export-preset "$PRESET" --methods "$list" --grids "$grids" "${budget[@]}" --no-progress
