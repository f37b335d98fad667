#!/usr/bin/env bash
# Keep a resumable copy of unfinished runs of scripts/results.sh in PARTIAL (default
# ~/mk-partial; never in git: only the bundled model and archived runs' final weights
# are), e.g. on storage that outlives the machine, so that a new one resumes them:
#
#   PARTIAL=/mnt/keep bash scripts/partial.sh navaff-12ep pointnet2-12ep  # RUNS/<name> -> PARTIAL/<name>
#   mkdir -p ~/mk-runs && cp -rn /mnt/keep/* ~/mk-runs/   # on the new machine, then
#   ONLY="navaff-12ep pointnet2-12ep" bash scripts/results.sh
#
# Each run is kept as it stood at its last checkpoint (an epoch's end, or within an epoch:
# train --checkpoint-minutes): weights, optimiser state and the log up to that step (a
# resume trims the log the same way). A training may go on
# beside it: if an epoch ends while the files are copied, they are copied again.
set -euo pipefail
RUNS=${RUNS:-$HOME/mk-runs}
PARTIAL=${PARTIAL:-$HOME/mk-partial}
if (($# == 0)); then
  echo "usage: bash scripts/partial.sh NAME [NAME ...] (runs in $RUNS)" >&2
  exit 2
fi
for name in "$@"; do
  src=$RUNS/$name
  if [[ ! -f $src/trainer_state.json ]]; then
    echo "partial.sh: $src has no checkpoint (no trainer_state.json)" >&2
    exit 2
  fi
done
for name in "$@"; do
  src=$RUNS/$name
  mkdir -p "$PARTIAL"
  tmp=$(mktemp -d "$PARTIAL/.partial-XXXXXX")
  # The files of one checkpoint: the trainer writes the weights, then trainer_state.safetensors,
  # then trainer_state.json, so neither may be newer than it, and it must not change.
  until
    before=$(cksum <"$src/trainer_state.json")
    cp "$src"/{config.json,model.safetensors,trainer_state.json,trainer_state.safetensors} "$tmp/"
    [[ "$(cksum <"$src/trainer_state.json")" == "$before" &&
      ! "$src/model.safetensors" -nt "$src/trainer_state.json" &&
      ! "$src/trainer_state.safetensors" -nt "$src/trainer_state.json" ]]
  do sleep 5; done
  step=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["progress"]["global_step"])' \
    "$tmp/trainer_state.json")
  awk -F, -v s="$step" 'NR == 1 || $3 <= s' "$src/log.csv" >"$tmp/log.csv"
  rm -rf "${PARTIAL:?}/$name"
  mv "$tmp" "$PARTIAL/$name"
  echo "$name: step $step -> $PARTIAL/$name"
done
