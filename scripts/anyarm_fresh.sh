#!/usr/bin/env bash
# The 40 N robots on held-out scenes of their own (descriptor version 2 data): the Elephant
# and the xArm6, labelled alone on scenes FIRST..FIRST+29, scored in closed loop and on the
# maps by the bundled NavAff, the 12-epoch PointNet++, the NavAff of several arms per
# reach (results/runs/navaff-anyarm-dense) and the one with grip forces too
# (GRIP_RUN, made by `VARIANT=grip bash scripts/anyarm.sh`), with the oracle and random;
# then scripts/anyarm_report.py, the trained robots' set taken from results/anyarm-930000
# (the any-arm test split, the same whatever the held-out scenes).
#
#   FIRST=940000 bash scripts/anyarm_fresh.sh   # DATA=~/mk-data RUNS=~/mk-runs
#
# Resumes: generation skips finished scenes, and results newer than their model are kept.
set -euo pipefail
DATA=${DATA:-$HOME/mk-data}
RUNS=${RUNS:-$HOME/mk-runs}
FIRST=${FIRST:-940000}
WORKERS=${WORKERS:-2}
REPO=$(cd "$(dirname "$0")/.." && pwd)
OUT=$REPO/results/anyarm-$FIRST
GRIP_RUN=${GRIP_RUN:-$RUNS/navaff-anyarm-grip}
BUNDLED=$(python3 -c "from momakitchen.train.checkpoint import default_checkpoint as d; print(d())")
# msr name=run directory; NavAffs also get maps (their name's last part)
MODELS=(
  "navaff=$BUNDLED"
  "pointnet2=$REPO/results/runs/pointnet2-12ep"
  "navaff:navaff-anyarm-dense=$REPO/results/runs/navaff-anyarm-dense"
  "navaff:navaff-anyarm-grip=$GRIP_RUN"
)
stamp() { echo "[$(date -u +%FT%TZ)] $*"; }
mkdir -p "$OUT"
rm -rf "$OUT/trained" && cp -r "$REPO/results/anyarm-930000/trained" "$OUT/trained"
for robot in elephant xarm6; do
  data=$DATA/heldout-$robot-$FIRST
  stamp "held-out $robot: 30 scenes from $FIRST"
  momakitchen generate --out "$data" --scenes 30 --first-scene-id "$FIRST" --robot "$robot" \
    --workers "$WORKERS" --quiet
  dir=$OUT/$robot
  mkdir -p "$dir"
  ckpt=()
  newest=0
  for m in "${MODELS[@]}"; do
    name=${m%%=*} run=${m#*=}
    ckpt+=(--checkpoint "$m")
    [[ "$run/model.safetensors" -nt "$dir/msr.json" ]] && newest=1
    [[ $name == navaff* ]] || continue
    maps=$dir/${name##*:}-maps.json
    if [[ ! -f $maps || "$run/model.safetensors" -nt $maps ]]; then
      stamp "maps of $name on $robot"
      momakitchen evaluate --data "$data" --split all --checkpoint "$run" --json "$maps" \
        --quiet >/dev/null
    fi
  done
  if [[ ! -f $dir/msr.json || $newest == 1 ]]; then
    stamp "closed loop on $robot"
    momakitchen msr --data "$data" --split all --top-k 1 --seed 0 "${ckpt[@]}" \
      --method oracle --method random --json "$dir/msr.json" --quiet >/dev/null
  fi
done
python3 "$REPO/scripts/anyarm_report.py" "$OUT"
