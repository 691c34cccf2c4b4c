#!/usr/bin/env bash
# The current report (issue 34; docs/benchmark.md "Reports"): every sweep on data=small at one capacity profile
# (cpu) and one training budget, with one commit's code, into one report folder, reports/small_current:
# the component study A-M (row I included), the baselines with OIDN and the noisy input, the spp sweep, the
# seeds sweep, transfer to the held-out scenes, and each job's learning curve (curves.png).
#
#   scripts/current_report.sh [stage ...]   # stages: ablation baselines spp seeds transfer report (default: all)
#
# Budget: train=plateau with train.max_steps=BUDGET_STEPS (default 1000), its cosine schedule spanning them
# (docs/training.md "Budgets"), for every trained job. Estimated cost per step of all jobs, from the step times
# that the report small_converged measured at the earlier capacity cpu (git show
# 98e0240:reports/small_converged/curves.csv: seconds over steps per method, AMD EPYC, two jobs sharing 2
# cores, one thread each; a shared machine, so rough) scaled by each method's MACs
# at the equal-share widths (python -m mcd.complexity): A-M about 10 s (I, K, L, M taken as F's), the
# five trained baselines and F_paper (taken as F's) about 10 s, spp about 11 s (F, NTASAD, A at 4 budgets), seeds
# about 7 s (A, B, C, F at 4 seeds), transfer about 1 s: about 39 CPU-seconds per step, so at 1000 steps about
# 11 CPU-hours with validation and testing, about 6 hours of wall time on 2 cores with JOBS=2, more than one
# session: the stages resume (below). 3000 steps, the budget of the earlier converged reports, would take three times that.
#
# Resumable across sessions: a sweep skips its finished jobs and resumes unfinished ones from their last.ckpt
# (ckpt_path=auto). The first stage records the commit and BUDGET_STEPS in <MULTIRUN>/<DATA>_current.commit, and
# a later session on other code (another commit, or uncommitted changes) or with another BUDGET_STEPS (the
# report stage included) is refused, so that the report is one commit's code at one budget.
# Each stage is one Hydra multirun on the joblib launcher (pip install 'mcd[cluster]'), JOBS (default 2) jobs
# at a time with one thread each (docs/training.md "CPU threads"). Needs MCD_SCENES_DIR for the small profile's
# scenes that are not vendored (docs/scenes.md).
#
# Variables: BUDGET_STEPS (1000), JOBS (2), DATA (small), MULTIRUN (./multirun: where the job directories go,
# <MULTIRUN>/<sweep>/<DATA>_current), OUT (reports: the reports root), NAME (<DATA>_current), PY
# (.venv/bin/python), REPORT_ARGS (more arguments for python -m mcd.report, e.g. --current NAME --readme PATH).
# The report stage writes OUT/NAME, the index OUT/README.md, and, when NAME is the current report
# (mcd.reporting.index.CURRENT_REPORT), README.md's results.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
DATA=${DATA:-small}
ROOT=$(realpath -m "${MULTIRUN:-multirun}")
TAG=_current
NAME=${NAME:-$DATA$TAG}
OUT=${OUT:-reports}
STEPS=${BUDGET_STEPS:-1000}
CAPACITY=capacity=cpu  # the capacity profile of every job
COMMON=(data="$DATA" train=plateau "train.max_steps=$STEPS" "$CAPACITY" trainer.enable_progress_bar=false)
LAUNCH=(hydra/launcher=joblib "hydra.launcher.n_jobs=${JOBS:-2}")  # one sweep, its jobs JOBS at a time
export OMP_NUM_THREADS=1

one_commit() {  # the code every job of the report runs: recorded by the first stage, checked by the others
  local mark="$ROOT/$DATA$TAG.commit" head
  head=$(git rev-parse HEAD)$(git diff --quiet HEAD -- mcd || echo +dirty)
  mkdir -p "$ROOT"
  if [ ! -f "$mark" ]; then echo "$head train.max_steps=$STEPS" > "$mark"; fi
  if [ "$(cut -d' ' -f1 "$mark")" != "$head" ]; then
    echo "error: $mark says the report's jobs run commit $(cut -d' ' -f1 "$mark"); this checkout is $head." >&2
    echo "Check out that commit, or remove $mark and the job directories under $ROOT/*/$DATA$TAG to start over." >&2
    exit 2
  fi
  one_budget record
}

one_budget() {  # the training budget of every job, recorded beside the commit: a session with another
  # BUDGET_STEPS would skip the finished jobs, train the others to its own budget, and the report's note would
  # state one budget for both
  local mark="$ROOT/$DATA$TAG.commit" recorded
  [ -f "$mark" ] || return 0
  recorded=$(sed -n 's/.* train\.max_steps=\([^ ]*\).*/\1/p' "$mark")
  if [ -z "$recorded" ]; then  # a mark of the script before it recorded the budget: a training stage records
    if [ "${1:-}" = record ]; then echo "$(cut -d' ' -f1 "$mark") train.max_steps=$STEPS" > "$mark"; fi
  elif [ "$recorded" != "$STEPS" ]; then
    echo "error: $mark says the report's jobs train train.max_steps=$recorded; this session has" \
      "BUDGET_STEPS=$STEPS." >&2
    echo "Give BUDGET_STEPS=$recorded, or another MULTIRUN (or remove $mark and the job directories under" \
      "$ROOT/*/$DATA$TAG) for another budget." >&2
    exit 2
  fi
}

sweep() {  # sweep <name> <experiments> [overrides...]
  local name=$1 experiments=$2; shift 2
  "$PY" -m mcd.run -m "+sweep=$name" "+experiment=$experiments" "${COMMON[@]}" "sweep_tag=$TAG" \
    "hydra.sweep.dir=$ROOT/$name/$DATA$TAG" "${LAUNCH[@]}" "$@"
}

stage() {
  case $1 in
    ablation) one_commit; sweep ablation A,B,C,D,E,F,G,H,I,J,K,L,M ;;   # the component study, row I included
    baselines) one_commit; sweep baselines rae,dasr,dasr_paper_loss,fastdvdnet,ntasad,oidn,noisy,F_paper ;;  # U-Net = row A
    spp) one_commit; sweep spp F,ntasad,A,oidn,noisy budget=2,8,16,32 ;;  # 4 spp: the ablation and baselines jobs
    seeds) one_commit; sweep seeds A,B,C,F seed=1,2,3,4 ;;           # seed 0: the ablation jobs
    transfer) one_commit; sweep transfer F,A "transfer.init_from=$ROOT/ablation/$DATA$TAG/\${experiment}_spp4" ;;
    report)
      one_budget
      local todo=() d  # the edge effect of each finished job not measured since it finished (tools/edge_effect.py)
      for d in "$ROOT"/*/"$DATA$TAG"/*/; do
        if [ -f "$d/metrics.json" ] && [ "$d/metrics.json" -nt "$d/edges.json" ]; then todo+=("$d"); fi
      done
      if [ ${#todo[@]} -gt 0 ]; then  # a job it cannot measure keeps an empty cell; the report still runs
        "$PY" -m tools.edge_effect "${todo[@]}" || echo "edge effect: some jobs not measured (above)" >&2
      fi
      # shellcheck disable=SC2086  # REPORT_ARGS is a list of words
      "$PY" -m mcd.report "$ROOT"/*/"$DATA$TAG" --name "$NAME" --out "$OUT" ${REPORT_ARGS:-} \
        --note "The current report: every sweep on data=$DATA at $CAPACITY, train=plateau with train.max_steps=$STEPS (cosine schedule to lr_min over them) for every trained job, at commit $(cut -d' ' -f1 "$ROOT/$DATA$TAG.commit" 2>/dev/null || echo unknown), JOBS=${JOBS:-2} jobs at a time with OMP_NUM_THREADS=1 (scripts/current_report.sh)." ;;
    *) echo "unknown stage $1 (ablation baselines spp seeds transfer report)" >&2; exit 2 ;;
  esac
}

for s in "${@:-ablation baselines spp seeds transfer report}"; do
  for t in $s; do stage "$t"; done
done
