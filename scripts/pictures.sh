#!/usr/bin/env bash
# Re-make the pictures under docs/img that the package draws, from small generated
# datasets, in about 8 minutes on 2 cores:
#
#   bash scripts/pictures.sh          # then: git diff --stat docs/img
#   bash scripts/pictures.sh --quick  # every step on the small dataset alone (2 minutes),
#                                     # into $OUT/img; docs/img is left as it is
#   OUT=/tmp/pictures bash scripts/pictures.sh   # where the datasets and runs go
#
# From the small dataset (2 scenes, 3 configurations of 3 views each): dataset_example.png
# (its card's example), predict.png (a test view as a Kinect with the camera pitched 2 deg
# off sees it), robustness.png (the bundled model's map of its first test view under every
# corruption, each panel's Top-1 outcome and PCC). From the commands alone: demo_report.png
# (`momakitchen demo`), scene_overview.png (`scene --scene-id 7`), labels_*.png
# (`label`), door_arc.png (scripts/door_arc.py). From the archived results, on the scenes
# they show, generated as those runs generated them (one scene each, default settings):
# approach.png (results/approach/final-bundled.json, scenes 710002 and 710006: one far-start
# episode per robot, and one of its failures, replayed), results_qualitative_300.png and
# results_qualitative_12ep.png (the archived navaff, pointnet2, h3dnet and votenet runs, 6
# and 12 epochs, on test scene 20003, one view per robot). A copy over 300 kB is reduced to
# 256 colours.
#
# audit_*.png (`momakitchen audit` on 10 development and 20 held-out scenes, 30 minutes
# each) are drawn again from the tables docs/LABELS.md archives under each picture, whole
# percent as printed there, without re-running the audits.
#
# Not re-made here: the pictures of archived studies at full scale, each made by the
# command its document gives (results_lambda_sweep*.png, results_navaff_loss.png,
# results_qualitative.png: runs of docs/results/HISTORY.md).
set -euo pipefail

QUICK=0
if [[ "${1:-}" == "--quick" ]]; then QUICK=1; shift; fi
if [[ $# -gt 0 ]]; then
  echo "usage: bash scripts/pictures.sh [--quick]   (OUT=DIR sets where the work goes)" >&2
  exit 2
fi
REPO=$(cd "$(dirname "$0")/.." && pwd)
OUT=${OUT:-$REPO/out/pictures}
IMG=$OUT/img
SMALL=$OUT/small
mkdir -p "$IMG"
cd "$REPO"
stamp() { echo "[$(date -u +%T)] $*"; }

stamp "the small dataset"
cat > "$OUT/small.yaml" <<'EOF'
scene:
  configs_per_scene: 3
views:
  episodes: 3
EOF
momakitchen generate --out "$SMALL" --scenes 2 --workers 2 --config "$OUT/small.yaml" --quiet
cp "$SMALL/example.png" "$IMG/dataset_example.png"
# Scene 0 is the dataset's test scene.
TEST_SCENE=$(python -c "import json,sys; m=json.load(open(sys.argv[1])); \
print(min(int(k) for k, v in m['shards'].items() if v['split'] == 'test'))" "$SMALL/manifest.json")

stamp "demo, scene, label, door arc"
rm -rf "$OUT/demo"
momakitchen demo --out "$OUT/demo" > /dev/null
cp "$OUT/demo/report.png" "$IMG/demo_report.png"
momakitchen scene --scene-id 7 --out "$OUT/scene7" > /dev/null
cp "$OUT/scene7/overview.png" "$IMG/scene_overview.png"
label() {  # NAME SCENE CONFIG [ROBOT]
  local robot=()
  if [[ -n "${4:-}" ]]; then robot=(--robot "$4"); fi
  momakitchen label --scene-id "$2" --config "$3" "${robot[@]}" --out "$OUT/$1" --quiet \
    > /dev/null
  cp "$OUT/$1/labels.png" "$IMG/$1.png"
}
label labels_flexiv_door 12 1
label labels_panda_bottle 12 0 panda
label labels_xarm6_bottle 12 0 xarm6
python scripts/door_arc.py --scene-id 1009 --config 0 --out "$IMG/door_arc.png" > /dev/null

stamp "predict"
python scripts/predict_picture.py --data "$SMALL" --scene-id "$TEST_SCENE" --sensor kinect \
  --pitch 2 --out "$OUT/predict" > /dev/null
cp "$OUT/predict/prediction.png" "$IMG/predict.png"

stamp "robustness"
python - "$SMALL" "$IMG/robustness.png" <<'PY'
import sys
from pathlib import Path

from momakitchen.eval.robustness.tables import robustness_figure
from momakitchen.eval.robustness.track import run_robustness
from momakitchen.eval.robustness.views import RobustnessConfig
from momakitchen.perception.sensors import CORRUPTIONS

data, out = sys.argv[1], Path(sys.argv[2])
names = ("clean", *(n for n in CORRUPTIONS if n != "clean"))
maps: dict = {}
config = RobustnessConfig(corruptions=names, max_configs=1)
result = run_robustness(data, None, config, progress=False, view_maps=maps)
first = result["records"][0]
model = next(iter(result["models"]))
title = (
    f"scene {first['scene_id']}, configuration {first['config_index']} ({first['target']}, "
    f"{first['robot']}), view {first['episode_index']}: {model}'s map under each corruption"
)
out.write_bytes(robustness_figure(maps, title, first["views"][model]))
PY

stamp "approach"
if [[ $QUICK == 1 ]]; then
  APPROACH_DATA=$SMALL
  momakitchen approach --data "$SMALL" --json "$OUT/approach/quick.json" --checkpoint bundled \
    --method oracle --start far --policy uncertain --quiet > /dev/null
  APPROACH_RESULT=$OUT/approach/quick.json
else
  APPROACH_DATA=$OUT/approach-scenes
  for s in 710002 710006; do
    momakitchen generate --out "$APPROACH_DATA" --scenes 1 --first-scene-id $s --split test \
      --quiet
  done
  APPROACH_RESULT=results/approach/final-bundled.json
fi
python - "$APPROACH_DATA" "$APPROACH_RESULT" "$IMG/approach.png" <<'PY'
import json
import sys
from pathlib import Path

from momakitchen.data.reader import dataset_generation
from momakitchen.eval.approach.episode import ModelPerceiver
from momakitchen.eval.approach.figure import episode_figure, figure_picks, replay
from momakitchen.train.checkpoint import default_checkpoint, load_checkpoint

data, result_file, out = Path(sys.argv[1]), sys.argv[2], Path(sys.argv[3])
manifest, _ = dataset_generation(data)
result = json.loads(Path(result_file).read_text())
# The episodes of the scenes at hand; the bundled model under the run's own name for it.
result["records"] = [r for r in result["records"] if str(r["scene_id"]) in manifest["shards"]]
model = next(r["method"] for r in result["records"] if r["policy"] != "-")
methods = {model: ModelPerceiver(load_checkpoint(default_checkpoint()), model)}
out.write_bytes(episode_figure(replay(data, result, figure_picks(result), methods)))
PY

stamp "qualitative"
if [[ $QUICK == 1 ]]; then
  QUAL_DATA=$SMALL
else
  QUAL_DATA=$OUT/scene20003
  momakitchen generate --out "$QUAL_DATA" --scenes 1 --first-scene-id 20003 --split test --quiet
fi
python - "$QUAL_DATA" "$IMG" <<'PY'
import sys
from pathlib import Path

from momakitchen.eval.report.figures import qualitative_figure

data, img = Path(sys.argv[1]), Path(sys.argv[2])
models = ("navaff", "pointnet2", "h3dnet", "votenet")
for suffix, picture in (("", "300"), ("-12ep", "12ep")):
    runs = [Path("results/runs") / f"{m}{suffix}" for m in models]
    figure = qualitative_figure(data, runs, examples=6)
    (img / f"results_qualitative_{picture}.png").write_bytes(figure)
PY

stamp "label audits (from docs/LABELS.md)"
python - docs/LABELS.md "$IMG" <<'PY'
import re
import sys
from pathlib import Path

from momakitchen.eval.audit import AuditConfig, audit_figure
from momakitchen.robots.spec import DEFAULT_ROBOTS

doc, img = Path(sys.argv[1]).read_text().splitlines(), Path(sys.argv[2])


def share(cell: str) -> float | None:
    return None if cell in ("–", "") else float(cell.removesuffix("%").strip()) / 100


# Each audit picture, and the table of its audit that follows it.
drawn = []
for i, line in enumerate(doc):
    picture = re.fullmatch(r"!\[[^\]]*\]\(img/(audit_\w+\.png)\)", line.strip())
    if not picture:
        continue
    start = next(j for j in range(i, len(doc)) if doc[j].startswith("| group |"))
    head = [c.strip() for c in doc[start].strip("|").split("|")]
    summary: dict = {"per_robot": {}, "per_target": {}}
    for row in doc[start + 2 :]:
        if not row.startswith("|"):
            break
        cells = dict(zip(head, (c.strip() for c in row.strip("|").split("|")), strict=True))
        name = cells["group"].strip("*")
        top1_feasible = cells["oracle Top-1 (all / feasible)"].split("/")[1].strip()
        figures = {
            "configurations": int(cells["configs"]),
            "infeasible": share(cells["infeasible"]),
            "stability": {"3cm": share(cells["stable ±3cm"])},
            "msr": {"oracle": {"top1_feasible": share(top1_feasible)}},
            "coverage": share(cells["view coverage"]),
        }
        if name == "all":
            summary["overall"] = figures
        else:
            summary["per_robot" if name in DEFAULT_ROBOTS else "per_target"][name] = figures
    (img / picture.group(1)).write_bytes(audit_figure(summary, AuditConfig()))
    drawn.append(picture.group(1))
assert len(drawn) == 4, f"docs/LABELS.md: audit pictures with their tables: {drawn}"
PY

if [[ $QUICK == 1 ]]; then
  stamp "done: $IMG (docs/img left as it is)"
  exit 0
fi
stamp "copies into docs/img"
python - "$IMG" docs/img <<'PY'
import shutil
import sys
from pathlib import Path

from PIL import Image

LIMIT = 300_000  # bytes: a larger picture is reduced to 256 colours
src, dst = Path(sys.argv[1]), Path(sys.argv[2])
for png in sorted(src.glob("*.png")):
    target = dst / png.name
    if png.stat().st_size <= LIMIT:
        shutil.copyfile(png, target)
    else:
        image = Image.open(png).convert("RGB")
        image.quantize(256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(
            target, optimize=True
        )
    print(f"{target}: {target.stat().st_size // 1000} kB")
PY
stamp "done: git diff --stat docs/img"
