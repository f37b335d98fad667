#!/usr/bin/env bash
# Robots the model never saw: the bundled NavAff and PointNet++ retrained on robots that
# vary continuously, and both before and after on held-out robots, in closed loop and on
# the maps (docs/RESULTS.md, "Robots the model never saw").
#
#   bash scripts/anyarm.sh             # DATA=~/mk-data RUNS=~/mk-runs by default
#   SCENES=60 HELDOUT_SCENES=6 bash scripts/anyarm.sh
#   RETRAIN=0 bash scripts/anyarm.sh   # score the bundled any-arm run, results/runs/navaff-anyarm
#   VARIANT=scaled bash scripts/anyarm.sh  # the same with arms of scaled links, after a run of the above
#   VARIANT=dense bash scripts/anyarm.sh   # several arms at every reach (NavAff only)
#   VARIANT=dense HELDOUT_FIRST=920000 bash scripts/anyarm.sh  # on other held-out scenes
#   VARIANT=grip bash scripts/anyarm.sh    # and each gripper at 40 N too (descriptor v2)
#   VARIANT=grip HELDOUT_FIRST=930000 ALONE=1 bash scripts/anyarm.sh  # add it to a scored set
#   VARIANT=rehearse bash scripts/anyarm.sh  # grip's data beside the six's own (no forgetting?)
#   VARIANT=shoulder HELDOUT_FIRST=950000 HELDOUT_SCENES=30 bash scripts/anyarm.sh
#                                            # grip's data, descriptor v3 (where the shoulder is)
#
# 1. The any-arm data (scripts/recipes/anyarm_generate.yaml): the Panda, Flexiv, UR5e,
#    Realman and UR10e, each configuration's mount drawn in 0.45-1.15 m; scenes from 30000.
# 2. Retraining (scripts/recipes/anyarm_finetune.yaml): the bundled NavAff and the
#    12-epoch PointNet++ (results/runs/pointnet2-12ep) fine-tuned on its train split,
#    side by side, one thread each. RETRAIN=0: no training; the any-arm NavAff is the one
#    in results/runs/navaff-anyarm (made by this step), and only the test split of step 1
#    is made.
# 3. Held-out robots, each labelled alone on the same kitchens (scenes from 910000, used
#    by no development step): the Elephant (the shortest reach) and the xArm6 (the lowest
#    mount), both left out of step 1; the Kinova Gen3 (an arm no training saw); the Panda
#    at 1.30 m and the UR5e at 0.35 m (mounts outside step 1's range).
# 4. On each held-out robot and on step 1's test split (the trained robots): msr Top-1 of
#    the models with the oracle and random (seed 0, every configuration), and the NavAff
#    models' map metrics (the PCC goal is theirs); then scripts/anyarm_report.py writes
#    results/anyarm/report.{json,md}.
# 5. The paper's six at their own mounts: the retrained NavAff on the 300-scene
#    benchmark's test split (SIX_DATA, its test scenes made if missing) as the bundled
#    model was measured there (evaluate; msr, seed 0, Top-5), compared with the bundled
#    model's archived results on the same bytes (scripts/run_compare.py), or, on other
#    bytes, with the bundled model run there again.
#
# VARIANT=scaled (SCALED=1), dense or grip (after a run without it, whose results it adds
# to): step 1's data is that of scripts/recipes/anyarm_VARIANT_generate.yaml (its train
# split in DATA/anyarm-VARIANT; the trained robots' test set stays step 1's): arms with
# scaled links, several arms of scaled links at every reach, or those and each gripper
# among them at 40 N too (robot descriptor version 2, which carries the finger force: the
# bundled model's weights are widened to it); rehearse: grip's data and beside it the
# train split of the bundled model's own recipe (the six at their mounts, the first
# SCENES ids of its scenes from 20000; DATA/six-train), so that the fine-tune also sees
# what the bundled model learned; shoulder: grip's data read with robot descriptor version 3,
# which adds where the shoulder stands (the others read the version they were first made
# with: scripts/recipes/anyarm_finetune_v1.yaml, _v2.yaml). Step 2 fine-tunes the bundled
# NavAff on it (RUNS/navaff-anyarm-VARIANT), and for scaled the 12-epoch PointNet++ too
# (RUNS/pointnet2-anyarm-scaled), or takes the committed results/runs/ ones with
# RETRAIN=0. Steps 4-5 score those beside the two they started from (msr-VARIANT.json;
# the report checks that the outcomes of those two there equal theirs in msr.json).
#
# HELDOUT_FIRST (default 910000): the held-out scenes' first id. Other ids make their own
# held-out data (DATA/heldout-NAME-ID) and results (results/anyarm-ID), where every model
# (the two, the scaled NavAff's committed run and the VARIANT's) and the baselines are
# scored together in msr.json; the six of step 5 stay in results/anyarm/six. ALONE=1 (with
# a VARIANT, on held-out scenes already scored): only the VARIANT's model is scored, in
# msr-VARIANT.json, which the report adds to msr.json (the same configurations).
#
# SIX=0 skips step 5 (the six at their own mounts: some 90 minutes on 2 cores with the
# generation of their test split).
#
# Every step resumes: generation skips finished scenes, training goes on from its last
# checkpoint, and results newer than their model are kept. Run it again after a stop.
set -euo pipefail

DATA=${DATA:-$HOME/mk-data}
RUNS=${RUNS:-$HOME/mk-runs}
SCENES=${SCENES:-60}
HELDOUT_SCENES=${HELDOUT_SCENES:-6}
WORKERS=${WORKERS:-2}
REPO=$(cd "$(dirname "$0")/.." && pwd)
HELDOUT_FIRST=${HELDOUT_FIRST:-910000}
SUFFIX=""
[[ $HELDOUT_FIRST != 910000 ]] && SUFFIX=-$HELDOUT_FIRST
OUT=${OUT:-$REPO/results/anyarm$SUFFIX}
SIX_OUT=$REPO/results/anyarm/six
RECIPES=$REPO/scripts/recipes
ANYARM=$DATA/anyarm
SIX_DATA=${SIX_DATA:-$DATA/gt2-300}
RETRAIN=${RETRAIN:-1}
VARIANT=${VARIANT:-}
[[ ${SCALED:-0} == 1 ]] && VARIANT=scaled
case $VARIANT in
  "" | scaled | dense | grip | rehearse | shoulder) ;;
  *) echo "VARIANT must be scaled, dense, grip, rehearse, shoulder or empty, got '$VARIANT'" >&2
     exit 2 ;;
esac
case $VARIANT in  # the descriptor version each variant's model reads
  "" | scaled | dense) FINETUNE=$RECIPES/anyarm_finetune_v1.yaml ;;
  grip | rehearse) FINETUNE=$RECIPES/anyarm_finetune_v2.yaml ;;
  *) FINETUNE=$RECIPES/anyarm_finetune.yaml ;;
esac
mkdir -p "$RUNS" "$OUT"

stamp() { echo "[$(date -u +%FT%TZ)] $*"; }

# name, robot, generation config ("" for the robot's own mount)
HELDOUT=(
  "elephant elephant"
  "xarm6 xarm6"
  "gen3 gen3"
  "panda-1.30 panda $RECIPES/mount_1.30.yaml"
  "ur5e-0.35 ur5e $RECIPES/mount_0.35.yaml"
)

split=()
[[ $RETRAIN == 0 || -n $VARIANT ]] && split=(--split test)
stamp "any-arm data: $SCENES scenes from 30000 in $ANYARM ${split[*]}"
momakitchen generate --out "$ANYARM" --scenes "$SCENES" --first-scene-id 30000 \
  --config "$RECIPES/anyarm_generate.yaml" --workers "$WORKERS" "${split[@]}" --quiet
TRAIN_DATA=(--data "$ANYARM")
if [[ -n $VARIANT ]]; then
  recipe=${VARIANT/rehearse/grip}  # rehearse: grip's data, and the six's beside it
  recipe=${recipe/shoulder/grip}
  TRAIN_DATA=(--data "$DATA/anyarm-$recipe")
  if [[ $RETRAIN == 1 ]]; then
    stamp "any-arm data, $recipe: $SCENES scenes from 30000 in $DATA/anyarm-$recipe (train split)"
    momakitchen generate --out "$DATA/anyarm-$recipe" --scenes "$SCENES" --first-scene-id 30000 \
      --config "$RECIPES/anyarm_${recipe}_generate.yaml" --robot-yaml "$RECIPES/robots" \
      --workers "$WORKERS" --split train --quiet
  fi
  if [[ $VARIANT == rehearse && $RETRAIN == 1 ]]; then
    stamp "the six's own data: $SCENES scenes from 20000 in $DATA/six-train (train split)"
    momakitchen generate --out "$DATA/six-train" --scenes "$SCENES" --first-scene-id 20000 \
      --workers "$WORKERS" --split train --quiet
    TRAIN_DATA+=(--data "$DATA/six-train")
  fi
fi

train_one() {  # name, model, initial run, more train options
  local resume=()
  [[ -f "$RUNS/$1/trainer_state.json" ]] && resume=(--resume)
  if [[ -f "$RUNS/$1/done" ]]; then return 0; fi
  stamp "train $1 (from $3)"
  momakitchen train "${TRAIN_DATA[@]}" --out "$RUNS/$1" --model "$2" --init "$3" \
    --config "$FINETUNE" "${resume[@]}" "${@:4}" --quiet >"$RUNS/$1.log" 2>&1
  touch "$RUNS/$1/done"
}
BUNDLED=$(python3 -c "from momakitchen.train.checkpoint import default_checkpoint as d; print(d())")
MODELS=("$BUNDLED" "$REPO/results/runs/pointnet2-12ep")
NAMES=(navaff pointnet2)  # the maps files of anyarm_report.py
MSR=msr.json
BASELINES=(--method oracle --method random)
LABELS=()  # msr's names of MODELS where not its own
RUN=anyarm
NAVAFF_OPTIONS=()
if [[ -n $VARIANT ]]; then
  # The two models again beside the new ones: the same outcomes as in msr.json, checked.
  MSR=msr-$VARIANT.json
  BASELINES=()
  RUN=anyarm-$VARIANT
  NAVAFF_OPTIONS=(--threads 2)  # as the committed runs, trained alone
fi
if [[ -n $SUFFIX ]]; then  # new held-out scenes: everything scored together
  MSR=msr.json
  BASELINES=(--method oracle --method random)
  if [[ $VARIANT != scaled ]]; then
    MODELS+=("$REPO/results/runs/navaff-anyarm-scaled")
    NAMES+=(navaff-anyarm-scaled)
  fi
fi
if [[ $RETRAIN == 1 ]]; then
  train_one "navaff-$RUN" navaff bundled "${NAVAFF_OPTIONS[@]}" &
  # PointNet++ beside it for the first two data (the descriptor comparison of the issue).
  [[ $VARIANT == scaled ]] && train_one "pointnet2-$RUN" pointnet2 "${MODELS[1]}" &
  wait
  NAVAFF_ANYARM=$RUNS/navaff-$RUN
  POINTNET2_ANYARM=$RUNS/pointnet2-$RUN
else
  NAVAFF_ANYARM=$REPO/results/runs/navaff-$RUN
  POINTNET2_ANYARM=$REPO/results/runs/pointnet2-$RUN  # committed for the scaled run only
fi
MODELS+=("$NAVAFF_ANYARM")
NAMES+=("navaff-$RUN")
if [[ -d $POINTNET2_ANYARM ]]; then
  MODELS+=("$POINTNET2_ANYARM")
  NAMES+=("pointnet2-$RUN")
fi
if [[ ${ALONE:-0} == 1 ]]; then
  if [[ -z $SUFFIX || -z $VARIANT ]]; then
    echo "ALONE=1 needs a VARIANT and a HELDOUT_FIRST other than 910000" >&2; exit 2
  fi
  MODELS=("$NAVAFF_ANYARM")
  NAMES=("navaff-$RUN")
  LABELS=("navaff:navaff-$RUN")  # msr's name of it beside the others (alone: "navaff")
  MSR=msr-$VARIANT.json
  BASELINES=()
fi

for spec in "${HELDOUT[@]}"; do
  read -r name robot config <<<"$spec"
  stamp "held-out $name: $HELDOUT_SCENES scenes from $HELDOUT_FIRST"
  momakitchen generate --out "$DATA/heldout-$name$SUFFIX" --scenes "$HELDOUT_SCENES" \
    --first-scene-id "$HELDOUT_FIRST" --robot "$robot" ${config:+--config "$config"} \
    --workers "$WORKERS" --quiet
done

score() {  # dataset, split, result name
  local dir=$OUT/$3 i ckpt=() newest=0
  mkdir -p "$dir"
  for i in "${!MODELS[@]}"; do
    ckpt+=(--checkpoint "${LABELS[$i]:+${LABELS[$i]}=}${MODELS[$i]}")
    [[ "${MODELS[$i]}/model.safetensors" -nt "$dir/$MSR" ]] && newest=1
    [[ ${NAMES[$i]} == navaff* ]] || continue  # PointNet++ enters the closed loop only
    if [[ ! -f "$dir/${NAMES[$i]}-maps.json" || "${MODELS[$i]}/model.safetensors" -nt "$dir/${NAMES[$i]}-maps.json" ]]; then
      stamp "maps of ${NAMES[$i]} on $3"
      momakitchen evaluate --data "$1" --split "$2" --checkpoint "${MODELS[$i]}" \
        --json "$dir/${NAMES[$i]}-maps.json" --quiet >/dev/null
    fi
  done
  if [[ ! -f "$dir/$MSR" || $newest == 1 ]]; then
    stamp "closed loop on $3"
    momakitchen msr --data "$1" --split "$2" --top-k 1 --seed 0 "${ckpt[@]}" \
      "${BASELINES[@]}" --json "$dir/$MSR" --quiet >/dev/null
  fi
}
score "$ANYARM" test trained
for spec in "${HELDOUT[@]}"; do
  read -r name _ <<<"$spec"
  score "$DATA/heldout-$name$SUFFIX" all "$name"
done
python3 "$REPO/scripts/anyarm_report.py" "$OUT"
[[ ${SIX:-1} == 0 ]] && exit 0

stamp "the six at their own mounts: $SIX_DATA (test split)"
momakitchen generate --out "$SIX_DATA" --scenes 300 --first-scene-id 20000 --split test \
  --workers "$WORKERS" --quiet
sum=$(python3 -c 'import json, sys
from momakitchen.data.manifest import split_checksum
print(split_checksum(json.load(open(sys.argv[1])), "test"))' "$SIX_DATA/manifest.json")
six() {  # run dir, result dir: its test.json and msr.json on SIX_DATA
  mkdir -p "$2"
  if [[ ! -f "$2/test.json" || "$1/model.safetensors" -nt "$2/test.json" ]]; then
    stamp "maps of $1 on the six"
    momakitchen evaluate --data "$SIX_DATA" --checkpoint "$1" --json "$2/test.json" --quiet >/dev/null
  fi
  if [[ ! -f "$2/msr.json" || "$1/model.safetensors" -nt "$2/msr.json" ]]; then
    stamp "closed loop of $1 on the six"
    momakitchen msr --data "$SIX_DATA" --checkpoint "$1" --seed 0 --json "$2/msr.json" --quiet >/dev/null
  fi
}
six "$NAVAFF_ANYARM" "$SIX_OUT/navaff-$RUN"
BEFORE=$REPO/results/runs/navaff-12ep-noise-mild  # the bundled model's archived run
# its results on the other bytes of these scenes (made on another CPU, docs/DATASET.md)
[[ "$(cat "$BEFORE/test-shards.sha256")" != "$sum" ]] && BEFORE=$BEFORE/shards-${sum:0:12}
if [[ "$(cat "$BEFORE/test-shards.sha256" 2>/dev/null)" != "$sum" ]]; then
  BEFORE=$SIX_OUT/navaff
  six "$BUNDLED" "$BEFORE"
fi
python3 "$REPO/scripts/run_compare.py" "bundled=$BEFORE" "$RUN=$SIX_OUT/navaff-$RUN" \
  | tee "$SIX_OUT/compare${RUN#anyarm}.md"
