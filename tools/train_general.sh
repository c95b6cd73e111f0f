#!/usr/bin/env bash
# The `general` model: generate its training maps, then train it warm-started from the paper model.
# Resumable end to end: run the same command again after an interruption (generation resumes shard
# by shard, training from last.pt with exactly the batches it would have seen).
#
#   tools/train_general.sh                       # defaults below; state under $NDRQL_CACHE
#   EPOCHS=4 STEPS=500 tools/train_general.sh    # a shorter schedule
#
# SEED is the seed of the generated training maps: 0..899999 (ndrql.limits.TRAINING_SEEDS; `ndrql data
# generate` and `ndrql train` refuse the evaluation seeds above). TRAIN_SEED is the training run's own
# seed (initialisation of new heads, batch order, augmentation): variance over training, e.g.
#   EPOCHS=2 STEPS=1000 TRAIN_SEED=1 TAG=var-s1 tools/train_general.sh EXCLUDE=maze,office trains on the same generated set without those families
# (leave-families-out runs: `ndrql train --exclude-families`). INIT= warm-starts from other weights
# (e.g. src/ndrql/data/ndr_general.pt to continue the shipped model); EXTRA=DIR:W adds a source.
# DISTANCE=1 trains only a goal-distance head on the fixed trunk of INIT (--distance-head --train-only distance):
#   DISTANCE=1 INIT=src/ndrql/data/ndr_general.pt COUNT=12000 EPOCHS=8 TAG=general-distance tools/train_general.sh
# DECODER=skips picks the kind of distance head (--distance-decoder; v5 of `general`):
#   DISTANCE=1 DECODER=skips INIT=src/ndrql/data/ndr_general.pt COUNT=12000 EPOCHS=8 TAG=general-skips tools/train_general.sh
# RANKING=raw+snapped also ranks the distance head's detours as Eq. 6 snaps them (--distance-rank; v6 of `general`):
#   DISTANCE=1 DECODER=skips RANKING=raw+snapped INIT=src/ndrql/data/ndr_general.pt COUNT=12000 EPOCHS=4 LR=5e-4 TAG=general-snap tools/train_general.sh
# RANKING=raw+snapped+moves also scores each cell's greedy move (training.losses.greedy_move_loss):
#   DISTANCE=1 DECODER=skips RANKING=raw+snapped+moves INIT=src/ndrql/data/ndr_general.pt COUNT=12000 EPOCHS=3 LR=5e-4 TAG=general-moves tools/train_general.sh
set -euo pipefail
cd "$(dirname "$0")/.."
NDRQL=${NDRQL:-.venv/bin/ndrql}
CACHE=${NDRQL_CACHE:-$HOME/.cache/ndrql}
DATA=${DATA:-../shared/data/path-planning-dataset}
MODE=${MODE:-grid}                 # what the model sees (studies/history.md#ceiling): grid or map
GRIDS=${GRIDS:-40,50,64,80,100,128}
COUNT=${COUNT:-20000}
SIZES=${SIZES:-201,401,801}
SEED=${SEED:-1}
TRAIN_SEED=${TRAIN_SEED:-0}
EPOCHS=${EPOCHS:-10}
STEPS=${STEPS:-1000}
LR=${LR:-1e-3}
THREADS=${THREADS:-2}
EXCLUDE=${EXCLUDE:-}
INIT=${INIT:-src/ndrql/data/ndr_default.pt}
EXTRA=${EXTRA:-}
DISTANCE=${DISTANCE:-}
DECODER=${DECODER:-}
RANKING=${RANKING:-}  # not RANK: torchrun reads that one
VIEW=${VIEW:-native}  # how the model sees large grids (ndrql.dataset.views; coarse:128 for the large-map model)
# the shipped general model's twelve families unless FAMILIES is given (FAMILIES=all: every registered one,
# the large-map families included, as studies/large_view/history.md plans the next model)
if [ "${FAMILIES:-}" = all ]; then
  FAMILIES=$(.venv/bin/python -c "from ndrql.synth.families import family_names; print(','.join(family_names()))")
else
  FAMILIES=${FAMILIES:-$(.venv/bin/python -c "from ndrql.synth.families import shipped_families; print(','.join(shipped_families()))")}
fi
TAG=${TAG:-general-${MODE}${EXCLUDE:+-no-${EXCLUDE//,/-}}}
GEN=$CACHE/gen/train-s${SEED}-${FAMILIES//,/-}
RUN=${RUN:-$CACHE/runs/$TAG}

echo "families: $FAMILIES${EXCLUDE:+ without $EXCLUDE}"
echo "data: $GEN"
echo "run: $RUN"
"$NDRQL" data generate --family "$FAMILIES" --count "$COUNT" --size "$SIZES" --seed "$SEED" --out "$GEN" --workers 2 --no-progress
RESUME=()
[ -f "$RUN/last.pt" ] && RESUME=(--resume)
HEAD=()
[ -n "$DISTANCE" ] && HEAD=(--distance-head --train-only distance ${DECODER:+--distance-decoder "$DECODER"} ${RANKING:+--distance-rank "$RANKING"})
exec "$NDRQL" train --data "$DATA" --sources "paper:1,$GEN:3${EXTRA:+,$EXTRA}" --input-mode "$MODE" --grid-sizes "$GRIDS" \
    --exclude-families "$EXCLUDE" --init-weights "$INIT" --epochs "$EPOCHS" --steps-per-epoch "$STEPS" --lr "$LR" \
    --warmup-steps 100 --seed "$TRAIN_SEED" --threads "$THREADS" --batch-size 16 --val-per-source 96 --checkpoint-minutes 3 \
    --view "$VIEW" --no-progress --run-dir "$RUN" "${HEAD[@]}" "${RESUME[@]}"
