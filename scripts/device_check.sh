#!/usr/bin/env bash
# The paper-scale checks on a GPU machine (docs/scale.md "Measured on a GPU"), one prepared script under one
# wall-clock budget, each step bounded by what is left of it and run even when an earlier one failed:
#
#   1. plan:    python -m mcd.plan data=paper capacity=paper train=paper, with a 1080p pilot render of
#               PILOT_FRAMES frames at PILOT_SPP spp on Mitsuba's CUDA variant and the training step measured
#               on the GPU (bf16 autocast, at batch 1 and at train.batch_size);
#   2. smoke:   the paper-shaped training of tests/scale/paper_smoke_run.py (capacity=paper row F, a synthetic
#               1920x1080 store packed into the training store, 256x256 crops, 5-frame clips, two loader
#               workers) on the GPU under trainer=ddp (NCCL, one rank) and bf16-mixed; per-step wall times;
#   3. profile: python -m mcd.bench profile of row F (capacity=paper) on the GPU at PROFILE_SIZE (1080p),
#               bf16 (before the speed step) and fp32 (after it): each stage's exclusive time from CUDA
#               events, refused (exit 3, no file) unless the stages add up to the frame within 10%
#               (docs/inference.md "Stage profile");
#   4. speed:   python -m mcd.bench speed on CUDA for SPEED_METHODS (F,unet,fastdvdnet) at SPEED_SIZES
#               (1080p), capacity=paper, eager paths (each method's own forward, so its fast paths);
#   5. compile: the same for row F with the torch.compile paths (max-autotune builds: minutes).
#
#   scripts/device_check.sh            # env: OUT (default outputs/device_check), PY (default python3),
#                                      # SECONDS_TOTAL (default 480), PILOT_SPP (default 32),
#                                      # PILOT_FRAMES (default 3), ACCEL (default gpu; cpu: a trial of
#                                      # the profile and speed steps on the CPU, e.g. with PROFILE_SIZE=128x96
#                                      # SPEED_SIZES=128x96), STEPS (default "plan smoke profile speed
#                                      # compile"), SMOKE_EXTRA (overrides appended to the smoke run's, e.g. a
#                                      # smaller frame for a trial on CPU)
#   SECONDS_TOTAL=200 STEPS="profile speed" scripts/device_check.sh      # the profile and speed steps only
#
# Writes OUT/check.log (every step's output), OUT/machine.txt, OUT/smoke_rank0.json, OUT/profile/F_bf16.md and
# OUT/profile/F_fp32.md, OUT/speed/bench.csv and OUT/compile/bench.csv (each with the README that mcd.bench
# writes beside it); a step that does not run writes nothing. Scenes: the vendored ones
# (MCD_SCENES_DIR defaults to scenes/ here, so the plan's pilot renders staircase2, the first of data=paper's
# scenes that is vendored).
set -u
cd "$(dirname "$0")/.."
OUT=$(realpath -m "${OUT:-outputs/device_check}")
PY=${PY:-python3}
ACCEL=${ACCEL:-gpu}
DEV=cuda
[[ $ACCEL == gpu ]] || DEV=cpu
STEPS=${STEPS:-plan smoke profile speed compile}
deadline=$(( $(date +%s) + ${SECONDS_TOTAL:-480} ))
export PYTHONUNBUFFERED=1 HYDRA_FULL_ERROR=1 MCD_SCENES_DIR=${MCD_SCENES_DIR:-$PWD/scenes}
export PYTHONPATH=$PWD${PYTHONPATH:+:$PYTHONPATH}
work=$(mktemp -d)
mkdir -p "$OUT"
log=$OUT/check.log

step() {  # step NAME LIMIT_S CMD...: runs CMD under min(LIMIT_S, time left), its output into the log
  local name=$1 limit=$2 left
  shift 2
  [[ " $STEPS " == *" ${name%%-*} "* ]] || return 0
  left=$(( deadline - $(date +%s) ))
  (( left < limit )) && limit=$left
  if (( limit < 20 )); then echo "== $name: skipped, ${left} s left" | tee -a "$log"; return; fi
  echo "== $name (limit ${limit} s): $*" | tee -a "$log"
  local t0=$(date +%s)
  timeout "$limit" "$@" >>"$log" 2>&1
  echo "== $name: exit $? after $(( $(date +%s) - t0 )) s" | tee -a "$log"
}

{
  date -u
  git rev-parse --short HEAD 2>/dev/null || true
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv 2>&1
  lscpu | grep -E "Model name|^CPU\(s\)" 2>&1
  "$PY" -c "import sys, torch, lightning; print(sys.version.split()[0], 'torch', torch.__version__, \
'lightning', lightning.__version__, 'cuda', torch.cuda.is_available() and torch.cuda.get_device_name())"
} >"$OUT/machine.txt" 2>&1
cat "$OUT/machine.txt" >>"$log"

step plan 150 "$PY" -m mcd.plan data=paper capacity=paper train=paper plan.pilot_scale=1 \
  "plan.pilot_spp=${PILOT_SPP:-32}" "plan.pilot_frames=${PILOT_FRAMES:-3}" "paths.data_dir=$work/plan"

smoke=(data.frames_per_segment=18 data.clip_len=5 train.epochs=6 "trainer.accelerator=$ACCEL"
       trainer.devices=1 ${SMOKE_EXTRA:-})
[[ $ACCEL == gpu ]] && smoke+=(trainer.precision=bf16-mixed)
step smoke-store 90 "$PY" -c "import sys; from tests.scale.paper_smoke_run import write_store; \
write_store(*sys.argv[1:])" "$work/smoke" "${smoke[@]}"
mkdir -p "$work/smoke_out"
step smoke 180 "$PY" tests/scale/paper_smoke_run.py "$work/smoke" "$work/smoke_out" "${smoke[@]}"
cp "$work/smoke_out/rank0.json" "$OUT/smoke_rank0.json" 2>/dev/null &&
"$PY" - "$OUT/smoke_rank0.json" >>"$log" 2>&1 <<'EOF'
import json, statistics, sys
r = json.load(open(sys.argv[1]))
t = [s["seconds"] for s in r["steps"]]
gaps = [b - a for a, b, s in zip(t, t[1:], r["steps"][1:]) if s["epoch"] > 0]
print(f"smoke: {r['global_step']} steps on {r['world']} rank(s), shapes {r['steps'][0]['shapes']['ref']}, "
      f"losses {[round(s['loss'], 4) for s in r['steps']]}, finite weights {r['finite_weights']}")
print(f"smoke: seconds between steps after epoch 0: median {statistics.median(gaps):.3f}, "
      f"min {min(gaps):.3f}, max {max(gaps):.3f} (validation of each epoch falls between epochs)")
EOF

# row F's stage profile on $DEV at PROFILE_SIZE; each dtype's table into OUT/profile/F_<dtype>.md
profile=("$PY" -m mcd.bench profile --device "$DEV" --size "${PROFILE_SIZE:-1080p}" --synthetic --warmup 2
         --repeat 5)
step profile-bf16 45 "${profile[@]}" --dtype bf16 --out "$OUT/profile/F_bf16.md" capacity=paper
step speed 100 "$PY" -m mcd.bench speed --devices "$DEV" --synthetic --no-cuda-compile \
  --methods "${SPEED_METHODS:-F,unet,fastdvdnet}" --sizes "${SPEED_SIZES:-1080p}" \
  --out "$OUT/speed/bench.csv" capacity=paper
step profile-fp32 45 "${profile[@]}" --dtype fp32 --out "$OUT/profile/F_fp32.md" capacity=paper
step compile 150 "$PY" -m mcd.bench speed --devices "$DEV" --synthetic --methods F --sizes 1080p \
  --out "$OUT/compile/bench.csv" capacity=paper
rm -rf "$work"
echo "== done: $(date -u)" | tee -a "$log"
