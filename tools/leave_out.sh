#!/usr/bin/env bash
# Leave-families-out transfer (studies/history.md#leave-families-out): one reference run on all 12 families and
# one run per group of 3 families left out, all with the same short budget, warm-started from the
# paper model on the same generated set (tools/train_general.sh); then each model plans the held-out
# evaluation set (`ndrql reproduce transfer`), so a family's drop is (excluded run) - (reference run)
# on that family. Resumable: run it again after an interruption.
#
#   tools/leave_out.sh                 # 5 runs x EPOCHS x STEPS, then 5 transfer reports
#
# Leave relatives out: a family's close relatives share its structure, so leaving one out alone
# overstates transfer. Relatives (docs/map-engine.md): traps (bugtrap, bugtraps); walls with openings
# (gaps, gaps_blocks, narrow_passage); scattered obstacles (blocks, scatter); buildings (rooms, office,
# ros_scan); lattices of corridors (maze, warehouse). One run per group:
#   GROUPS_="none bugtrap,bugtraps gaps,gaps_blocks,narrow_passage blocks,scatter rooms,office,ros_scan maze,warehouse" \
#     OUT=results/leave-relatives-out tools/leave_out.sh
# The transfer reports run on the development set `transfer` (docs/results.md#evaluation-sets-and-how-often-they-were-read).
set -euo pipefail
cd "$(dirname "$0")/.."
NDRQL=${NDRQL:-.venv/bin/ndrql}
CACHE=${NDRQL_CACHE:-$HOME/.cache/ndrql}
OUT=${OUT:-results/leave-out}
export EPOCHS=${EPOCHS:-2} STEPS=${STEPS:-1000}
GROUPS_=${GROUPS_:-"none blocks,maze,ros_scan bugtrap,office,scatter bugtraps,gaps_blocks,warehouse gaps,narrow_passage,rooms"}
for group in $GROUPS_; do
    ex=$([ "$group" = none ] && echo "" || echo "$group")
    tag=lofo-${group//,/-}
    run=$CACHE/runs/$tag
    if [ ! -f "$run/weights.pt" ]; then
        EXCLUDE=$ex TAG=$tag tools/train_general.sh
        "$NDRQL" export-weights "$run/best.pt" --out "$run/weights.pt"
    fi
    [ -f "$OUT/$tag/summary.json" ] || "$NDRQL" reproduce transfer --weights "$run/weights.pt" --grids 50,100 \
        --seeds 10 --per-family 20 --workers 2 --out "$OUT/$tag"
done
