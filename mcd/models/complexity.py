"""Params and 1920x1080 MACs of every registered experiment beside the paper's (docs/benchmark.md "Metrics").

``python -m mcd.complexity [--model paper] [--experiments A B ...]`` prints the table and writes
``reports/complexity.csv`` (``name, params_m, gmacs_1080p, paper_params_m, paper_gmacs``; NaN and an
"unavailable" note in the printed table for a method whose optional package is missing). Experiments are the
files ``conf/experiment/*.yaml``, so a new method only needs its config (and its paper numbers in
:mod:`mcd.paper_numbers`).

MACs = FLOPs / 2 of one forward pass producing one output frame, whole pipeline, counted by
``torch.utils.flop_counter.FlopCounterMode``. The count runs on the ``meta`` device (shapes only, no memory,
instant at 1080p); ``tests/models/test_complexity.py`` shows it equals the count of a real CPU forward.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

import torch
from torch import nn
from torch.utils import flop_counter

from mcd.data.synthetic import synthetic_frame
from mcd.paper_numbers import paper_complexity

CONF_DIR = Path(__file__).resolve().parent.parent / "conf"


def _cpu_flash_attention_flop(query, key, value, *args, out_shape=None, **kwargs) -> int:
    """FLOPs of CPU flash attention, which ``FlopCounterMode`` does not count by itself (gets shapes)."""
    return flop_counter.sdpa_flop_count(query, key, value)


def flop_counter_mode() -> flop_counter.FlopCounterMode:
    """A ``FlopCounterMode`` that also counts CPU flash attention (so CPU, CUDA and meta counts agree)."""
    mapping = {torch.ops.aten._scaled_dot_product_flash_attention_for_cpu: _cpu_flash_attention_flop}
    return flop_counter.FlopCounterMode(display=False, custom_mapping=mapping)


def dummy_batch(model: nn.Module, height: int, width: int, device: torch.device | str,
                batch: int = 1) -> dict[str, torch.Tensor | None]:
    """Synthetic inputs for ``model.required_buffers()`` (:func:`mcd.data.synthetic.synthetic_frame`; ``ref``
    None, as at test time)."""
    past, future = getattr(model, "window", (0, 0))
    frames = past + 1 + future
    lead = (batch,) if frames == 1 else (batch, frames)
    return {"ref": None, **synthetic_frame(model.required_buffers(), height, width, lead, device=device)}


def count_params(model: nn.Module) -> int:
    """Trainable parameters; for a method that runs a network torch does not hold (OIDN), that network's
    (``model.network_params()``)."""
    if hasattr(model, "network_params"):
        return int(model.network_params())
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


def count_macs(model: nn.Module, height: int = 1080, width: int = 1920, device: str = "meta") -> int:
    """MACs of one forward pass of ``model`` (on ``device``) producing one ``height x width`` frame."""
    model.eval()
    if hasattr(model, "reset"):
        model.reset()
    x = dummy_batch(model, height, width, device)
    with torch.no_grad(), flop_counter_mode() as counter:
        model(x)
    if hasattr(model, "reset"):
        model.reset()
    return counter.get_total_flops() // 2


def complexity(cfg, height: int = 1080, width: int = 1920, device: str = "meta") -> tuple[float, float]:
    """``(params in M, GMACs)`` of the method ``cfg`` describes, built on ``device``."""
    from mcd.models import build

    with torch.device(device):
        model = build(cfg)
    return count_params(model) / 1e6, count_macs(model, height, width, device) / 1e9


def experiment_names() -> list[str]:
    """Every experiment config (``conf/experiment/*.yaml``), component rows A-M first."""
    names = [p.stem for p in (CONF_DIR / "experiment").glob("*.yaml")]
    return sorted(names, key=lambda n: (len(n) != 1, n))


def compose(experiment: str, model: str):
    """The run config of ``+experiment=<experiment> model=<model>``."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    with initialize_config_dir(config_dir=str(CONF_DIR), version_base=None):
        return hydra_compose(config_name="config", overrides=[f"+experiment={experiment}", f"model={model}"])


def table(experiments: list[str], model: str, height: int, width: int,
          unavailable: dict[str, str] | None = None) -> list[dict]:
    """One row per experiment: ours and the paper's params and GMACs (NaN where either is missing).

    A method whose optional package is missing (OIDN without ``pyoidn``) gets NaN and its reason in
    ``unavailable`` (name -> message) instead of stopping the table.
    """
    rows = []
    for name in experiments:
        cfg = compose(name, model)
        try:
            params, gmacs = complexity(cfg, height, width)
        except ImportError as err:
            params, gmacs = math.nan, math.nan
            if unavailable is not None:
                unavailable[name] = str(err)
        paper = paper_complexity(name, cfg.method.name) or {"params_m": math.nan, "gmacs": math.nan}
        rows.append({"name": name, "params_m": round(params, 4), "gmacs_1080p": round(gmacs, 2),
                     "paper_params_m": paper["params_m"], "paper_gmacs": paper["gmacs"]})
    return rows


def _rel(ours: float, paper: float) -> str:
    return "" if math.isnan(paper) else f"{100 * (ours / paper - 1):+.1f}%"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="paper", help="capacity profile (conf/model/<name>.yaml)")
    parser.add_argument("--experiments", nargs="*", default=None,
                        help="default: every conf/experiment/*.yaml")
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--width", type=int, default=1920)
    parser.add_argument("--out", default="reports/complexity.csv")
    args = parser.parse_args(argv)
    unavailable: dict[str, str] = {}
    rows = table(args.experiments or experiment_names(), args.model, args.height, args.width, unavailable)
    print(f"model={args.model}, {args.width}x{args.height}, MACs = FlopCounterMode FLOPs / 2")
    print(f"{'name':<12}{'params_m':>10}{'paper':>8}{'diff':>8}{'gmacs':>10}{'paper':>9}{'diff':>8}")
    for r in rows:
        print(f"{r['name']:<12}{r['params_m']:>10.3f}{r['paper_params_m']:>8.3f}"
              f"{_rel(r['params_m'], r['paper_params_m']):>8}{r['gmacs_1080p']:>10.2f}"
              f"{r['paper_gmacs']:>9.2f}{_rel(r['gmacs_1080p'], r['paper_gmacs']):>8}"
              + (f"  unavailable: {unavailable[r['name']]}" if r["name"] in unavailable else ""))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
