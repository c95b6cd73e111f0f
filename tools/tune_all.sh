#!/usr/bin/env bash
# The searches behind the shipped `tuned` preset (studies/history.md#tuning): one Optuna study per
# method, the same budget for every method, then the preset and its check on fresh seeds.
#
#   tools/tune_all.sh                         # QL, O-QL, IQL, NDR-QL; then src/ndrql/planning/presets/tuned.json
#   METHODS="D-C N-C" tools/tune_all.sh       # other methods, same budget
#
# Resumable: run it again after any interruption and each study continues where it stopped (a
# finished one returns at once). Studies live in results/tune/studies.db (outside git).
set -euo pipefail
cd "$(dirname "$0")/.."
NDRQL=${NDRQL:-.venv/bin/ndrql}
METHODS=${METHODS:-QL O-QL IQL NDR-QL}
TRIALS=${TRIALS:-200}
SAMPLES=${SAMPLES:-100}
SEEDS=${SEEDS:-10}
WORKERS=${WORKERS:-2}
PRESET=${PRESET:-src/ndrql/planning/presets/tuned.json}
budget=(--trials "$TRIALS" --samples "$SAMPLES" --seeds "$SEEDS" --workers "$WORKERS" --out results/tune)

for m in $METHODS; do
  echo "$(date -u +%FT%TZ) tune $m" >&2
  nice -n 5 "$NDRQL" tune --method "$m" "${budget[@]}" --no-progress
done
list=$(echo "${EXPORT_METHODS:-$METHODS}" | tr ' ' ',')
NDRQL_WRITE_PACKAGE=1 nice -n 5 "$NDRQL" tune --export-preset "$PRESET" --methods "$list" "${budget[@]}" --no-progress
