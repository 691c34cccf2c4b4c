#!/usr/bin/env bash
# The converged reports of issue 12 (docs/benchmark.md "Reports"): every trained job of data=small under one
# budget, train=plateau (3000 steps, cosine to lr_min; docs/training.md "Budgets"), then `python -m mcd.report`.
#
#   scripts/converged_reports.sh [stage ...]  # stages: ablation baselines transfer spp seeds rest budget part2 report
#
# Job directories go to <MULTIRUN>/<sweep>/small_converged, the report to reports/small_converged. The budget
# stage asks whether that budget is enough: F and NTASAD (the best trained baseline) again with more steps
# (train.max_steps=$BUDGET_STEPS, default 6000, the cosine schedule spanning them), in
# <MULTIRUN>/baselines/small_converged_s<steps>, reported in reports/small_converged_s<steps>. The part2
# stage (not in the default list) runs the component rows the first machine left unfinished (I, K, L, M) on a
# second one, with the noisy input and OIDN to compare its re-rendered store with the first, into
# <MULTIRUN>/*/small_converged_part2 and reports/small_converged_part2: the first machine's run directories
# were lost with it, before reports kept their runs' records (mcd/reporting/records.py). The first pass,
# multirun/*/small_plateau and reports/small_plateau (same budget), ran before the baselines took the output
# steps of rows A-M and before pixels without geometry kept the render's value (docs/baselines.md "Output").
#
# Each stage is one Hydra multirun on the joblib launcher (hydra-joblib-launcher, `pip install 'mcd[cluster]'`),
# JOBS (default 2) jobs at a time with one thread each (docs/training.md "CPU threads"). Safe to stop and run again:
# a sweep skips its finished jobs and resumes unfinished ones from their last.ckpt (ckpt_path=auto), so the
# whole set can span several sessions of a 2-core machine. Needs MCD_SCENES_DIR for the small profile's
# non-vendored scenes (docs/scenes.md). MULTIRUN (default ./multirun) is where the job directories go.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
ROOT=$(realpath -m "${MULTIRUN:-multirun}")
TAG=_converged
STEPS=${BUDGET_STEPS:-6000}  # the budget stage's steps
COMMON=(data=small train=plateau trainer.enable_progress_bar=false)
LAUNCH=(hydra/launcher=joblib "hydra.launcher.n_jobs=${JOBS:-2}")  # one sweep, its jobs JOBS at a time
export OMP_NUM_THREADS=1

sweep() {  # [SUFFIX=<tag suffix>] sweep <name> <experiments> [overrides...]
  local name=$1 experiments=$2; shift 2
  local tag=$TAG${SUFFIX:-}
  "$PY" -m mcd.run -m "+sweep=$name" "+experiment=$experiments" "${COMMON[@]}" "sweep_tag=$tag" \
    "hydra.sweep.dir=$ROOT/$name/small$tag" "${LAUNCH[@]}" "$@"
}

stage() {
  case $1 in
    ablation) sweep ablation A,B,C,D,E,F ;;                     # the component chain: the paper's two claims
    baselines) sweep baselines rae,dasr,dasr_paper_loss,oidn,fastdvdnet,ntasad,noisy ;;  # U-Net = row A
    transfer) sweep transfer F,A "transfer.init_from=$ROOT/ablation/small$TAG/\${experiment}_spp4" ;;
    seeds) sweep seeds A,F,B,C seed=1,2,3,4 ;;                   # seed 0: the ablation jobs
    spp) sweep spp F,ntasad,noisy,A,oidn budget=2,8,16,32 ;;
    rest) sweep ablation G,H,I,J,K,L,M ;;
    budget) SUFFIX=_s$STEPS sweep baselines F,ntasad "train.max_steps=$STEPS" ;;  # is 3000 steps enough?
    part2)  # the rows the first machine did not finish, with the noisy input and OIDN to check the store matches
      SUFFIX=_part2 sweep baselines noisy,oidn
      SUFFIX=_part2 sweep ablation I,K,L,M ;;
    report)
      local todo=() d  # the edge effect of each finished job not measured since it finished (mcd/tools/edge_effect.py)
      for d in "$ROOT"/*/small$TAG/*/ "$ROOT"/*/small${TAG}_s[0-9]*/*/ "$ROOT"/*/small${TAG}_part2/*/; do
        if [ -f "$d/metrics.json" ] && [ "$d/metrics.json" -nt "$d/edges.json" ]; then todo+=("$d"); fi
      done
      if [ ${#todo[@]} -gt 0 ]; then  # a job it cannot measure keeps an empty cell; the report still runs
        "$PY" -m mcd.tools.edge_effect "${todo[@]}" || echo "edge effect: some jobs not measured (above)" >&2
      fi
      # reports/small_converged was generated from run directories that were lost with the first machine (its
      # multirun/ is not in git); on a machine without F's finished job it is left as committed
      if [ -f "$ROOT/ablation/small$TAG/F_spp4/metrics.json" ]; then
        "$PY" -m mcd.report "$ROOT"/*/small$TAG --name small$TAG \
          --note "Budget: train=plateau (3000 optimiser steps, cosine schedule to lr_min, no wall-clock limit) on data=small, capacity=cpu, two jobs at a time with OMP_NUM_THREADS=1 (scripts/converged_reports.sh). Output steps, not in the paper, the same for every method (docs/method.md 'Output', docs/baselines.md 'Output'): every learned method matches the frame mean of the render it denoised, and every method but the noisy input keeps the render's value where the G-buffer saw no geometry; the two-stage rows' F_d is residual. Jobs from commit a81b678 on give a pixel at the sampling map's per-pixel cap no DASR gradient (docs/method.md 'Adaptive sampling', step 4); the cap binds mainly at 32 spp, and the 32-spp jobs of adaptive methods were rerun with it (the earlier ones are in multirun/retired/). Resumed runs name each process's commit from commit 4aeff82 on; of the earlier ones, the session notes have the first process of F_spp4_seed3 (45 of its 52 min) at e32c668, before the cap rule, and that of ntasad_spp32 (37 of 43 min) at a81b678, with it."
      else echo "no $ROOT/ablation/small$TAG/F_spp4/metrics.json: reports/small$TAG left as it is" >&2; fi
      if compgen -G "$ROOT/*/small${TAG}_part2/*/metrics.json" > /dev/null; then
        "$PY" -m mcd.report "$ROOT"/*/small${TAG}_part2 --name "small${TAG}_part2" \
          --note "Part 2 of the converged pass (reports/small_converged): the rows of the component study the first machine did not finish, under the same budget (train=plateau: 3000 optimiser steps, cosine schedule to lr_min) on data=small, capacity=cpu, two jobs at a time with OMP_NUM_THREADS=1 (scripts/converged_reports.sh, stage part2). The first machine's run directories were lost with it, so these rows could not join that report: they ran on a second machine, on a store rendered again from the same profile and code; the noisy input and OIDN (no training) are here to show whether that store is the same as the first: compare their rows with reports/small_converged's."
      fi
      local b n
      for b in "$ROOT"/baselines/small${TAG}_s[0-9]*; do
        compgen -G "$b/*/metrics.json" > /dev/null || continue
        n=${b##*_s}
        "$PY" -m mcd.report "$b" --name "small${TAG}_s$n" \
          --note "Budget: train=plateau with train.max_steps=$n (against the 3000 steps of reports/small_converged, the cosine schedule to lr_min spanning them) on data=small, capacity=cpu, threads as in the Device(s) line (scripts/converged_reports.sh, stage budget with BUDGET_STEPS=$n): whether F and NTASAD, the best trained baseline at 4 spp, gain from more training than the converged pass gave them. Same data, seed (0), budget (4 spp) and output steps as reports/small_converged; compare each method with its own row there. A method that has no row here has not been trained with $n steps yet; rows from a second machine compare with reports/small_converged only through its noisy input and OIDN (reports/small_converged_part2, benchmarks/report_agreement.py)."
      done ;;
    *) echo "unknown stage $1 (ablation baselines transfer spp seeds rest budget part2 report)" >&2; exit 2 ;;
  esac
}

for s in "${@:-ablation baselines transfer spp seeds rest budget report}"; do
  for t in $s; do stage "$t"; done
done
