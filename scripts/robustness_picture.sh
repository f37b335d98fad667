#!/usr/bin/env bash
# The README's robustness picture (docs/img/robustness.png): the bundled model's map of one
# held-out view (the first test configuration of scene 450001, seed 0: msr's view) under
# every corruption `momakitchen robustness --list` names, on one 0-1 scale. A few minutes
# on one core (the scene's generation is most of it).
#
#   bash scripts/robustness_picture.sh [DATA] [OUT]    # then: git diff --stat docs/img
set -euo pipefail
DATA=${1:-data/rob450001}
OUT=${2:-out/robustness-picture}
momakitchen generate --out "$DATA" --scenes 1 --first-scene-id 450001 --split test --quiet
momakitchen robustness --data "$DATA" --max-configs 1 --json "$OUT/robustness.json" \
  --out "$OUT" --quiet
cp "$OUT/robustness.png" docs/img/robustness.png
