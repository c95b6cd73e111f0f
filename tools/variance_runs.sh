#!/usr/bin/env bash
# Variance over training and a leave-relatives-out run (docs/results.md "Variance over training").
# Short runs of one recipe that differ only in the training seed (TRAIN_SEEDS), plus one run per group
# of related families left out (GROUPS_, ';'-separated groups of ','-separated families), each
# warm-started from the paper model on the same generated maps, then the development report on
# `select` (never a sealed set), run by run. Resumable: finished runs and reports are skipped. The
# defaults (600 steps on grids 40-64, about 18 min a run on two idle cores) are what this machine affords.
#
#   GEN=~/.cache/ndrql/gen/train-s4-all18 tools/variance_runs.sh
#   python tools/variance_table.py results/variance          # the tables of docs/results.md
set -euo pipefail
cd "$(dirname "$0")/.."
NDRQL=${NDRQL:-.venv/bin/ndrql}
CACHE=${NDRQL_CACHE:-$HOME/.cache/ndrql}
DATA=${DATA:-../shared/data/path-planning-dataset}
GEN=${GEN:?GEN= a folder of generated training maps (ndrql data generate)}
TRAIN_SEEDS=${TRAIN_SEEDS:-0 1 2}
GROUPS_=${GROUPS_:-maze,warehouse,corridor_maze}
EPOCHS=${EPOCHS:-2}
STEPS=${STEPS:-300}
GRIDS=${GRIDS:-40,50,64}
EVAL_GRIDS=${EVAL_GRIDS:-50}
EVAL_SEEDS=${EVAL_SEEDS:-5}
ROWS=${ROWS:-IQL,NDR-QL (model),NDR-QL (oracle)}
OUT=${OUT:-results/variance}
PREFIX=${PREFIX:-var}
THREADS=${THREADS:-2}

train() {  # train TAG SEED EXCLUDE
  local run=$CACHE/runs/$1 resume=()
  [ -f "$run/weights.pt" ] && return 0
  [ -f "$run/last.pt" ] && resume=(--resume)
  "$NDRQL" train --data "$DATA" --sources "paper:1,$GEN:3" --input-mode grid --grid-sizes "$GRIDS" \
    --exclude-families "$3" --init-weights src/ndrql/data/ndr_default.pt --epochs "$EPOCHS" \
    --steps-per-epoch "$STEPS" --lr 1e-3 --warmup-steps 100 --seed "$2" --threads "$THREADS" --batch-size 16 \
    --val-per-source 96 --checkpoint-minutes 3 --no-progress --run-dir "$run" "${resume[@]}"
  "$NDRQL" export-weights "$run/best.pt" --out "$run/weights.pt"
}

report() {  # report TAG
  [ -f "$OUT/$1-general/summary.json" ] && return 0  # reproduce transfer appends the preset's name
  "$NDRQL" reproduce transfer --eval-set select --weights "$CACHE/runs/$1/weights.pt" --preset general \
    --grids "$EVAL_GRIDS" --seeds "$EVAL_SEEDS" --rows "$ROWS" --workers 2 --out "$OUT/$1"
}

for s in $TRAIN_SEEDS; do train "$PREFIX-s$s" "$s" ""; report "$PREFIX-s$s"; done
IFS=';' read -r -a groups <<< "$GROUPS_"
for g in "${groups[@]}"; do train "$PREFIX-no-${g//,/-}" 0 "$g"; report "$PREFIX-no-${g//,/-}"; done
