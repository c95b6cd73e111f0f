#!/usr/bin/env bash
# Train the models behind docs/results.md's Table 1 peer row, Table 4 and the width/precision
# comparison of docs/model.md, in two lanes of one-thread `ndrql train` processes (measured on this
# 2-core CPU: two 1-thread processes use the machine better than one 2-thread process).
#
#   tools/train_comparisons.sh            # both lanes in the background, logs in $RUNS/*.log
#   tools/train_comparisons.sh a          # lane a only, in the foreground (b likewise)
#
# Every run is resumable: run the script again after any interruption and each run continues from
# its last.pt (a finished run returns at once). State stays outside git, under $RUNS.
set -euo pipefail
cd "$(dirname "$0")/.."
NDRQL=${NDRQL:-.venv/bin/ndrql}
RUNS=${RUNS:-${NDRQL_CACHE:-$HOME/.cache/ndrql}/runs}
EPOCHS=${EPOCHS:-2}   # Table 4 and width comparison budget: a complete cosine schedule of this many epochs

run() {  # run NAME ARGS...: one training run in $RUNS/NAME, resumed when it has a last.pt
  local name=$1; shift
  local dir=$RUNS/$name resume=()
  [[ -f $dir/last.pt ]] && resume=(--resume)
  mkdir -p "$dir"
  echo "$(date -u +%FT%TZ) start $name: $*" >>"$RUNS/lanes.log"
  "$NDRQL" train --threads 1 --no-progress --run-dir "$dir" "${resume[@]}" "$@" >>"$dir/train.log" 2>&1
  echo "$(date -u +%FT%TZ) done $name" >>"$RUNS/lanes.log"
}

lane_a() {
  run rgp --model rgp --epochs 7                                         # Table 1 peer: the shipped NDR's 7 epochs
  run table4/point --model ndr-stdc1-half-noguide --encoding point --epochs "$EPOCHS"
  run table4/distance --model ndr-stdc1-half-noguide --encoding distance --epochs "$EPOCHS"
  run width/quarter --model ndr-stdc1-quarter --epochs "$EPOCHS"
  run precision/half-fp32 --model ndr-stdc1-half --no-bf16 --epochs "$EPOCHS"
}

lane_b() {
  run table4/point+GD --model ndr-stdc1-half --epochs "$EPOCHS"          # also the width comparison's half
  run table4/rgb --model ndr-stdc1-half-noguide --encoding rgb --epochs "$EPOCHS"
  run table4/gauss25 --model ndr-stdc1-half-noguide --encoding gauss25 --epochs "$EPOCHS"
  run table4/gauss50 --model ndr-stdc1-half-noguide --encoding gauss50 --epochs "$EPOCHS"
  run width/full --model ndr-stdc1 --model-overrides '{"unet_base": 8}' --epochs "$EPOCHS"
}

mkdir -p "$RUNS"
case "${1:-both}" in
  a) lane_a ;;
  b) lane_b ;;
  both) nohup "$0" a >>"$RUNS/lane_a.log" 2>&1 &
        nohup "$0" b >>"$RUNS/lane_b.log" 2>&1 &
        echo "lanes started; progress: tail -f $RUNS/lanes.log $RUNS/*/train.log $RUNS/*/*/train.log" ;;
  *) echo "usage: $0 [a|b|both]" >&2; exit 2 ;;
esac
