#!/usr/bin/env bash
# The scaling study's GPU leg (docs/scale.md "The scaling study on a GPU"), one prepared script for a device
# window under one wall-clock budget:
#
#   1. render: python -m mcd.render data=$PROFILE render.buffers=all on Mitsuba's CUDA variant (every buffer of
#              every scene, so each method below reads the one store);
#   2. train:  the METHODS at once on the one device (bf16-mixed on a GPU), each `python -m mcd.run
#              +experiment=<m>` with the study's recipe (train=plateau: the cosine schedule to lr_min spread
#              over the budget) under a wall-clock budget of what is left, minus a reserve for the test; far
#              more steps than the CPU legs (train.max_steps=$MAX_STEPS caps them);
#   3. test:   each run tests itself on the profile's test scenes (mcd.run's own test and record);
#   4. pack:   the run directories (metrics.json, frames.csv, curve.csv, logs, .hydra/, the best checkpoint;
#              no sample images) as one archive that `python -m mcd.report` reads back on the development
#              machine (reports/scaling/gpu/).
#
#   scripts/device_study.sh     # env: OUT (default outputs/device_study), PY (default python3),
#                               # SECONDS_TOTAL (default 400), PROFILE (default small), ACCEL (gpu | cpu,
#                               # default gpu), METHODS (default "F F_paper ntasad A"), MAX_STEPS (default
#                               # 100000), SEED (default 0), TEST_RESERVE_S (default 75), EXTRA (Hydra
#                               # overrides appended to every command, e.g. a smaller profile for a CPU trial)
#
# Writes at most four files into OUT: machine.txt, study.log (every step's output and each run's last lines),
# summary.csv (one row per method: steps, wall seconds, test PSNR/SSIM/rMSE/FLIP) and runs.tar.gz (the run
# directories, under 15 MiB: the checkpoints are left out when they would not fit). Scenes: the vendored ones
# and MCD_SCENES_DIR (default: shared/scenes beside the checkout when it exists, else scenes/).
set -u
cd "$(dirname "$0")/.."
OUT=$(realpath -m "${OUT:-outputs/device_study}")
PY=${PY:-python3}
ACCEL=${ACCEL:-gpu}
PROFILE=${PROFILE:-small}
METHODS=${METHODS:-F F_paper ntasad A}
MAX_STEPS=${MAX_STEPS:-100000}
SEED=${SEED:-0}
TEST_RESERVE_S=${TEST_RESERVE_S:-75}
read -r -a extra <<<"${EXTRA:-}"
start=$(date +%s)
deadline=$(( start + ${SECONDS_TOTAL:-400} ))
if [[ -z ${MCD_SCENES_DIR:-} ]]; then
  if [[ -d ../shared/scenes ]]; then MCD_SCENES_DIR=$(realpath ../shared/scenes); else MCD_SCENES_DIR=$PWD/scenes; fi
fi
export PYTHONUNBUFFERED=1 HYDRA_FULL_ERROR=1 MCD_SCENES_DIR
export PYTHONPATH=$PWD${PYTHONPATH:+:$PYTHONPATH}
work=$(mktemp -d)
data=$work/data
runs=$work/runs
mkdir -p "$OUT" "$runs"
log=$OUT/study.log
: >"$log"
common=("data=$PROFILE" "paths.data_dir=$data" "seed=$SEED")
if [[ $ACCEL == gpu ]]; then
  variant=cuda_ad_rgb
  device=(trainer.accelerator=gpu trainer.devices=1 trainer.precision=bf16-mixed train.val_every_steps=250)
else
  variant=auto
  device=(trainer.accelerator=cpu trainer.devices=1)
fi

left() { echo $(( deadline - $(date +%s) )); }

{
  date -u
  git rev-parse --short HEAD 2>/dev/null || true
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv 2>&1 || true
  lscpu | grep -E "Model name|^CPU\(s\)" 2>&1
  "$PY" -c "import sys, torch, lightning, mitsuba; print(sys.version.split()[0], 'torch', torch.__version__, \
'lightning', lightning.__version__, 'mitsuba', mitsuba.__version__, 'cuda', \
torch.cuda.is_available() and torch.cuda.get_device_name())"
  echo "profile $PROFILE, methods $METHODS, accel $ACCEL, seconds ${SECONDS_TOTAL:-400}, extra ${EXTRA:-}"
} >"$OUT/machine.txt" 2>&1
cat "$OUT/machine.txt" >>"$log"

# 1. render (bounded by half of what is left: the training is the point)
limit=$(( $(left) / 2 ))
echo "== render (limit ${limit} s)" | tee -a "$log"
t0=$(date +%s)
timeout "$limit" "$PY" -m mcd.render "${common[@]}" render.buffers=all "render.variant=$variant" "${extra[@]}" \
  >>"$log" 2>&1
rc=$?
echo "== render: exit $rc after $(( $(date +%s) - t0 )) s" | tee -a "$log"

# 2-3. train and test every method at once, under what is left less the test's reserve
minutes=$(awk -v s="$(( $(left) - TEST_RESERVE_S ))" 'BEGIN { printf "%.2f", (s > 6 ? s : 6) / 60 }')
echo "== train: $METHODS at once, train.max_minutes=$minutes, train.max_steps=$MAX_STEPS" | tee -a "$log"
pids=()
for m in $METHODS; do
  timeout "$(( $(left) > 10 ? $(left) : 10 ))" "$PY" -m mcd.run "+experiment=$m" "${common[@]}" train=plateau \
    "train.max_steps=$MAX_STEPS" "train.max_minutes=$minutes" trainer.enable_progress_bar=false \
    "${device[@]}" "hydra.run.dir=$runs/$m" "${extra[@]}" >"$work/$m.log" 2>&1 &
  pids+=("$!")
done
i=0
for m in $METHODS; do
  wait "${pids[$i]}"
  echo "== $m: exit $? ($(( $(date +%s) - t0 )) s since the render began)" | tee -a "$log"
  { echo "-- $m: last lines"; tail -n 40 "$work/$m.log"; } >>"$log"
  i=$(( i + 1 ))
done

# 4. the summary and the run directories
"$PY" - "$runs" "$OUT/summary.csv" $METHODS >>"$log" 2>&1 <<'EOF'
import csv, json, sys
from pathlib import Path
runs, out, methods = Path(sys.argv[1]), sys.argv[2], sys.argv[3:]
cols = ["experiment", "train_steps", "stop_reason", "train_s", "wall_s", "psnr", "ssim", "rmse", "flip",
        "input_psnr", "input_flip", "best_val_psnr", "precision", "device"]
with open(out, "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(cols)
    for m in methods:
        p = runs / m / "metrics.json"
        r = json.loads(p.read_text()) if p.exists() else {"experiment": m}
        w.writerow([r.get(c, "") for c in cols])
print(open(out).read())
EOF
pack() { tar -czf "$OUT/runs.tar.gz" -C "$work" --exclude='*.exr' --exclude='*.png' --exclude='last.ckpt' "$@" runs; }
pack
if (( $(stat -c %s "$OUT/runs.tar.gz") > 15 * 1024 * 1024 )); then
  echo "== runs.tar.gz over 15 MiB with checkpoints: packed without them" | tee -a "$log"
  pack --exclude='*.ckpt'
fi
rm -rf "$work"
echo "== done after $(( $(date +%s) - start )) s: $(date -u)" | tee -a "$log"
