"""The last thing ``python -m mcd.run`` prints: what happened (docs/training.md, "Progress and summary").

:func:`summary` turns a run's ``metrics.json`` (``mcd.lit.run_record.RunRecord``) into a few lines: why
training stopped (epochs, step or time budget, plateau) with the steps done, the training and wall time; the
test scores PSNR / SSIM / rMSE / FLIP with the noisy input's beside each; the same per scene; and where the
run directory and the tested checkpoint are.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

#: The scores of the summary: key in metrics.json, label, format. Each has the noisy input's ``input_<key>``.
SCORES = (("psnr", "PSNR dB", "{:.2f}"), ("ssim", "SSIM", "{:.4f}"), ("rmse", "rMSE", "{:.4g}"),
          ("flip", "FLIP", "{:.4f}"))

#: Why training stopped (mcd.lit.budget.stop_reason), in words; ``{}`` takes the setting's value.
STOP_REASONS = {
    "max_steps": "the step budget (train.max_steps={max_steps})",
    "max_minutes": "the time budget (train.max_minutes={max_minutes})",
    "epochs": "the epoch budget (train.epochs={epochs})",
    "plateau": "a plateau of val/psnr (train.patience={patience} validations without a gain)",
    "not trained": "nothing: the method is tested as built (or as transferred)",
    "interrupted": "an interruption before any budget was reached",
}


def _fmt(value: Any, spec: str) -> str:
    """``value`` formatted, or ``n/a`` for a missing or non-finite one (JSON null)."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "n/a"
    return spec.format(value)


def _minutes(seconds: float | None) -> str:
    if seconds is None:
        return "n/a"
    return f"{seconds / 60:.1f} min" if seconds >= 60 else f"{seconds:.1f} s"


def summary(metrics: dict[str, Any], run_dir: Path, train: dict[str, Any]) -> str:
    """The summary of a finished run (see the module docstring). ``metrics``: what ``metrics.json`` holds;
    ``train``: the run's resolved ``train`` settings (for the budget that stopped it)."""
    reason = str(metrics.get("stop_reason"))
    why = STOP_REASONS.get(reason, reason).format(**{k: train.get(k) for k in
                                                     ("max_steps", "max_minutes", "epochs", "patience")})
    segments = metrics.get("segments") or []
    resumed = f", resumed: {len(segments)} training processes" if len(segments) > 1 else ""
    lines = [f"run summary of {metrics.get('experiment')} (budget {metrics.get('budget')} spp, seed "
             f"{metrics.get('seed')})",
             f"  training stopped by {why} after {metrics.get('train_steps')} steps, "
             f"{metrics.get('epochs')} epochs, {_minutes(metrics.get('train_s'))} of training{resumed}; "
             f"wall time {_minutes(metrics.get('wall_s'))}",
             "  test scores:"]
    per_scene = metrics.get("per_scene") or {}
    tested = f"{sum((metrics.get('test_frames') or {}).values())} frames, {len(per_scene)} scene(s)"
    lines.append(f"    {tested:<24}{'output':>9}  {'noisy input':>11}")
    for key, label, spec in SCORES:
        out, noisy = _fmt(metrics.get(key), spec), _fmt(metrics.get("input_" + key), spec)
        lines.append(f"    {label:<24}{out:>9}  {noisy:>11}")
    lines.append("  per scene, output (noisy input): " + ", ".join(label for _, label, _ in SCORES))
    for scene, scores in per_scene.items():
        cells = [f"{_fmt(scores.get(k), spec)} ({_fmt(scores.get('input_' + k), spec)})"
                 for k, _, spec in SCORES]
        lines.append(f"    {scene}: " + "   ".join(cells))
    transfer = metrics.get("transfer") or {}
    untrained = (f"none (the weights of transfer.init_from {transfer['init_from']})"
                 if transfer.get("init_from") else "none (the model as built)")
    lines += [f"  run directory: {run_dir}",
              f"  checkpoint tested: {metrics.get('checkpoint') or untrained}"]
    return "\n".join(lines)
