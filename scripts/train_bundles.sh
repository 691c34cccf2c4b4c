#!/usr/bin/env bash
# Train the bundled checkpoints (docs/denoise.md "Bundled checkpoints"): row F and the U-Net (row A) on
# data=medium (twelve training scenes: eight real ones and four procedural rooms; dining-room, veach-ajar and
# kitchenette held out) with OIDN's augmentations of docs/training.md "Augmentations" on (flips, transpose, RGB
# permutation, exposure, zero padding; reversed clips are off, as for every method with a motion buffer), for
# 10000 steps; then bundle them into mcd/bundled/ as F-medium and unet-medium and score them on medium's held-out
# scenes and on bathroom's test frames beside OIDN (tools/bundle_scores.py, a lab tool), writing the table into
# docs/denoise.md.
#
#   scripts/train_bundles.sh [hydra override ...]   # overrides reach both trainings and the scoring
#
# Env: PY (default .venv/bin/python); STAGES (default "train bundle score"); OUT (default outputs/bundles: the
# two run directories and their logs); STEPS (default 10000, train=plateau's budget) and MINUTES (default null:
# a wall-clock cap of each training, validation included); BUNDLE_DIR (default mcd/bundled); DOC (default
# docs/denoise.md). The two trainings run at once, one thread each (docs/training.md "CPU threads"); a rerun
# resumes an unfinished training from its last.ckpt (ckpt_path=auto). Needs MCD_SCENES_DIR for the held-out
# interiors (docs/scenes.md).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
OUT=$(realpath -m "${OUT:-outputs/bundles}")
BUNDLE_DIR=${BUNDLE_DIR:-mcd/bundled}
NAMES=(F-medium unet-medium)
declare -A EXPERIMENT=([F-medium]=F [unet-medium]=A)
AUGMENT=(data.augment.flips=true data.augment.transpose=true data.augment.channels=true data.augment.zero_pad=0.1
  data.augment.exposure_stops=2.0 data.augment.reverse=false)  # OIDN's set (conf/data/bundle.yaml's values)
SCORED='data.transfer_scenes=[dining-room,veach-ajar,kitchenette,bathroom]'  # held out, and bathroom's test frames
export OMP_NUM_THREADS=1

# The trainings read their clips from the packed training store (docs/training_store.md; packed by the first
# run, float32, the EXR values bit for bit): medium keeps no frames in memory, so the EXR path decodes every
# clip of every step (measured: notes/scaling_plan.md, "The packed store for medium").
# The trainings leave the held-out interiors out of their store work ('data.transfer_scenes=[]': mcd.run
# renders every frame of a profile's transfer scenes); the score stage renders only their test frames.
train() {
  mkdir -p "$OUT"
  local name pids=()
  for name in "${NAMES[@]}"; do
    "$PY" -m mcd.run "+experiment=${EXPERIMENT[$name]}" data=medium "${AUGMENT[@]}" train=plateau \
      data.train_store.format=array \
      "train.max_steps=${STEPS:-10000}" \
      "train.max_minutes=${MINUTES:-null}" trainer.enable_progress_bar=false ckpt_path=auto \
      'data.transfer_scenes=[]' "hydra.run.dir=$OUT/$name" "$@" > "$OUT/$name.log" 2>&1 &
    pids+=($!)
  done
  for pid in "${pids[@]}"; do wait "$pid"; done
}

for stage in ${STAGES:-train bundle score}; do
  case $stage in
    train) train "$@" ;;
    bundle) for name in "${NAMES[@]}"; do "$PY" -m mcd.bundle "$OUT/$name" --name "$name" --out "$BUNDLE_DIR" --replace; done ;;
    score)
      bundles=()
      for name in "${NAMES[@]}"; do bundles+=(--bundle "$BUNDLE_DIR/$name.pt"); done
      bundles+=(--bundle F-cpu-bundle --bundle F-cpu-small --bundle unet-cpu-small)  # the previous bundles
      PYTHONPATH=. "$PY" tools/bundle_scores.py "${bundles[@]}" --data medium --write "${DOC:-docs/denoise.md}" "$SCORED" "$@" ;;
    *) echo "unknown stage $stage (train, bundle, score)" >&2; exit 2 ;;
  esac
done
