#!/usr/bin/env bash
# The model for belief maps (issue 54): training pairs of the map engine with beliefs, then a run warm-started
# from `general` with one more input channel (encoding point+unknown: 1 on the cells unknown to the planner; at
# step 0 it predicts exactly what general predicts on the belief). Resumable end to end: the same command again
# after an interruption (generation resumes shard by shard, training from last.pt).
#
#   tools/train_belief.sh data                              # the training set only (resumable)
#   tools/train_belief.sh bench                             # 16 steps: prints steps/min to set STEPS_PER_MIN
#   TAG=belief-short-a tools/train_belief.sh short          # a short run: SHORT_MIN minutes (default 20)
#   TAG=belief-short-b LR=1e-3 tools/train_belief.sh short  # another candidate (studies/partial/README.md, "Training plan")
#   TAG=belief-long LR=... tools/train_belief.sh long       # the long run: LONG_MIN minutes (default 100)
#   SEED=2 MASK_SEED=55 tools/train_belief.sh data         # a second set: other maps, other beliefs
#   TAG=belief-long3 INIT=src/ndrql/data/ndr_belief.pt EXTRA=$CACHE/gen/train-s2-belief-m55-n12000:3 tools/train_belief.sh long
#   SEED=3 MASK_SEED=56 MASKS=blobs:0.1-0.5,sensed,none:0.1 tools/train_belief.sh data   # the third set (leg 5)
#   SEED=3 MASK_SEED=56 MASKS=blobs:0.1-0.5,sensed,none:0.1 TAG=belief-leg5 INIT=src/ndrql/data/ndr_belief.pt \
#     EXTRA=$CACHE/gen/train-s1-belief-m54-n12000:3,$CACHE/gen/train-s2-belief-m55-n12000:3 UNKNOWN_WEIGHT=2 LR=3e-4 tools/train_belief.sh long
#                                                         # leg 5 (kept in studies/partial/weights, not shipped)
#   TAG=belief-long tools/train_belief.sh export            # best.pt -> $CACHE/belief/ndr_belief.pt (view coarse:128)
#
# The maps are general's training maps (its twelve families, 201/401/801 px, SEED=1: the known-map samples
# are the very maps general learned from); each sample also holds a belief drawn from MASK_SEED
# (`ndrql data generate --masks`: blobs hiding 10-50% of the free space, what a robot sensed along 1-3
# routes, an outdated map, and a share NONE of samples with nothing hidden). Both seeds are training seeds
# (0..899999); `ndrql data generate` refuses the evaluation seeds. The paper's dataset joins as known maps.
# Labels are the TRUE map's route and goal distances; the input is the belief's grid and its unknown cells.
set -euo pipefail
cd "$(dirname "$0")/.."
NDRQL=${NDRQL:-.venv/bin/ndrql}
PY=${PY:-.venv/bin/python}
CACHE=${NDRQL_CACHE:-$HOME/.cache/ndrql}
DATA=${DATA:-../shared/data/path-planning-dataset}
GRIDS=${GRIDS:-40,50,64,80,100,128}   # general's grids (native view); served above 128 under coarse:128
COUNT=${COUNT:-12000}
SIZES=${SIZES:-201,401,801}
SEED=${SEED:-1}
MASK_SEED=${MASK_SEED:-54}
NONE=${NONE:-0.2}
MASKS=${MASKS:-blobs:0.1-0.5,sensed,outdated,none:$NONE}
PAPER=${PAPER:-1}                     # weight of the paper's dataset (known maps); 0 = left out
WEIGHT=${WEIGHT:-3}                   # weight of the belief set
EXTRA=${EXTRA:-}                      # more sources, "DIR:WEIGHT,..." (e.g. a second belief set of other seeds)
TRAIN_SEED=${TRAIN_SEED:-0}
LR=${LR:-5e-4}
UNKNOWN_WEIGHT=${UNKNOWN_WEIGHT:-0}   # extra loss weight of the unknown pixels (--unknown-weight; 0 = legs 1-4)
THREADS=${THREADS:-2}
STEPS_PER_MIN=${STEPS_PER_MIN:-36}    # measured by `bench`; 36 = 0.6 steps/s (see studies/partial/README.md)
SHORT_MIN=${SHORT_MIN:-20}
LONG_MIN=${LONG_MIN:-100}
INIT=${INIT:-src/ndrql/data/ndr_general.pt}
FAMILIES=${FAMILIES:-$($PY -c "from ndrql.synth.families import shipped_families; print(','.join(shipped_families()))")}
GEN=${GEN:-$CACHE/gen/train-s${SEED}-belief-m${MASK_SEED}-n${COUNT}}
ACTION=${1:-short}
TAG=${TAG:-belief-$ACTION}
RUN=${RUN:-$CACHE/runs/$TAG}

generate() {
  echo "data: $GEN (masks $MASKS, mask seed $MASK_SEED)"
  "$NDRQL" data generate --family "$FAMILIES" --count "$COUNT" --size "$SIZES" --seed "$SEED" \
      --masks "$MASKS" --mask-seed "$MASK_SEED" --out "$GEN" --workers 2 --no-progress
}

train() {  # train EPOCHS STEPS RUN_DIR [extra flags]
  local epochs=$1 steps=$2 run=$3
  shift 3
  local sources="$GEN:$WEIGHT"
  [ -n "$EXTRA" ] && sources="$sources,$EXTRA"
  [ "$PAPER" != 0 ] && sources="paper:$PAPER,$sources"
  local resume=()
  [ -f "$run/last.pt" ] && resume=(--resume)
  echo "run: $run ($epochs x $steps steps, lr $LR, $THREADS threads, sources $sources)"
  "$NDRQL" train --data "$DATA" --sources "$sources" --model ndr-stdc1-half --encoding point+unknown \
      --input-mode grid --grid-sizes "$GRIDS" --distance-head --distance-decoder skips --distance-rank raw+snapped --unknown-weight "$UNKNOWN_WEIGHT" \
      --init-weights "$INIT" --epochs "$epochs" --steps-per-epoch "$steps" --lr "$LR" --warmup-steps 100 \
      --seed "$TRAIN_SEED" --threads "$THREADS" --batch-size 16 --val-per-source 96 --checkpoint-minutes 3 \
      --no-progress --run-dir "$run" "${resume[@]}" "$@"
}

case "$ACTION" in
  data) generate ;;
  bench)
    generate
    rm -rf "$CACHE/runs/belief-bench"
    train 1 16 "$CACHE/runs/belief-bench" --max-steps 16 --val-per-source 4
    "$PY" -c "
import torch; s = torch.load('$CACHE/runs/belief-bench/last.pt', weights_only=True, map_location='cpu')['state']
print(f\"{s['global_step']} steps in {s['train_seconds']:.0f} s: STEPS_PER_MIN={60 * s['global_step'] / s['train_seconds']:.0f}\")" ;;
  short)
    generate
    total=$((SHORT_MIN * STEPS_PER_MIN))
    train 2 $((total / 2)) "$RUN" ;;
  long)
    generate
    total=$((LONG_MIN * STEPS_PER_MIN))
    train 5 $((total / 5)) "$RUN" ;;
  export)
    mkdir -p "$CACHE/belief"
    "$NDRQL" export-weights "$RUN/best.pt" --out "$CACHE/belief/ndr_belief.pt" --view coarse:128 --merged-weights "" ;;
  *) echo "usage: tools/train_belief.sh data|bench|short|long|export (see the header)" >&2; exit 2 ;;
esac
