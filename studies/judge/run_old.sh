set -x
export PYTHONPATH=/work/old/src
PY=/work/main/.venv/bin/python
ROWS="IQL,IQL (BFS distance),NDR-QL (model),NDR-QL (oracle)"
for spec in "large-dev2-128 128" "large-dev2-256 256" "transfer 50,100"; do
  set -- $spec
  nice -n 5 $PY -m ndrql reproduce transfer --eval-set $1 --grids $2 --weights general --preset general --seeds 3 --workers 2 --per-family 8 --rows "$ROWS" --out /work/runs/old-$1 --no-progress
done
