"""``python -m mcd.bundle <run dir> --name <name>``: a finished run -> a bundled checkpoint
(docs/denoise.md, "Bundled checkpoints").

Writes ``mcd/bundled/<name>.pt`` (the model's weights only: a flat state dict of float tensors, loadable with
``weights_only=True``) and ``<name>.json``: its provenance (the ``mcd.run`` command that trained it, the
commit and whether the tree was dirty, the data profile, the budget in samples per pixel, the training budget
and why it stopped, the device, the test metrics from the run's ``metrics.json``), the SHA-256 of the ``.pt``
and the configuration the model is built from (``experiment``, ``method``, ``model``, ``budget``, the data
keys the inputs are normalised with). ``--checkpoint <name>`` of ``mcd-denoise`` then finds it. The weights
are checked against the model they are built into, and for NaN/Inf values, before anything is written. A
bundle of that name already in the folder (a shipped one included) is kept: the command refuses it unless
``--replace`` is given.
Both files are written atomically (:mod:`mcd.core.atomic_write`), so a killed bundle leaves no half file.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch
import yaml
from omegaconf import DictConfig, OmegaConf

from mcd.core.atomic_write import atomic_write
from mcd.core.paths import check_folder_name, writable_folder_to_be
from mcd.denoise.weights import BUNDLED_DIR, check_finite, check_schema, tested_checkpoint
from mcd.lit import checkpoint

#: Keys of a run's metrics.json copied into the provenance.
METRICS = ("psnr", "ssim", "rmse", "lt", "input_psnr", "input_ssim", "input_rmse", "per_scene",
           "scenes_test", "params_m", "macs_g", "best_val_psnr", "train_steps", "stop_reason", "epochs",
           "train_s", "wall_s", "commit", "dirty", "device", "torch", "precision", "data_profile",
           "capacity_profile", "train_profile", "budget", "seed", "experiment")
#: Data keys the inputs are normalised with (mcd.data.exposure) and the scene renders use, and what the model
#: was trained on: its scenes, the held-out ones, the augmentations (docs/training.md, "Augmentations").
DATA_KEYS = ("name", "exposure_target", "max_depth", "gbuffer_spp", "ref_spp", "width", "height",
             "train_scenes", "transfer_scenes", "augment")


class BundleExistsError(FileExistsError):
    """A bundle of the name is already in the output folder, and ``--replace`` was not given."""


def bundle(run_dir: Path, name: str, out_dir: Path = BUNDLED_DIR,
           source_commit: str | None = None, replace: bool = False) -> dict[str, Any]:
    """Write ``<out_dir>/<name>.pt`` and ``.json`` from ``run_dir`` (module docstring); returns the JSON.

    ``source_commit``: the commit the run's code was exported from, for a run outside a git checkout (its
    ``metrics.json`` then says ``commit: unknown``); recorded as given, beside the run's own record.
    ``replace``: write over a bundle of that name (else :class:`BundleExistsError`, before anything is read).
    """
    from mcd.models import build

    check_folder_name(name, "--name", f"the bundle is written as {out_dir}/<name>.pt and .json")
    writable_folder_to_be("--out", out_dir)  # a file, or below one: named before the run is read
    taken = [p for p in (out_dir / f"{name}.pt", out_dir / f"{name}.json") if p.exists() or p.is_symlink()]
    if taken and not replace:
        raise BundleExistsError(
            f"{' and '.join(map(str, taken))}: a bundle named {name!r} is already there; give another "
            "--name, or --replace to write over it")
    metrics_path = run_dir / "metrics.json"
    if not metrics_path.is_file():
        raise FileNotFoundError(f"{metrics_path}: missing; bundle a finished run of python -m mcd.run")
    metrics = read_record(metrics_path, json.loads, dict, "a JSON object")
    ckpt = tested_checkpoint(run_dir, "run dir")
    if ckpt is None:
        raise FileNotFoundError(f"{run_dir / 'checkpoints'}: no best*.ckpt or last.ckpt; bundle a finished "
                                "run of python -m mcd.run that trained")
    state = checkpoint.safe_load(ckpt, "run dir")
    cfg = OmegaConf.create(state["hyper_parameters"]["cfg"])
    check_schema(cfg, f"{ckpt}: its training config")
    trained = str(cfg.get("experiment", cfg.method.name))
    if metrics.get("experiment") not in (None, trained):
        raise ValueError(f"{ckpt}: a checkpoint of experiment {trained!r}, but {metrics_path} records "
                         f"{metrics.get('experiment')!r}; its metrics are not this checkpoint's: bundle the "
                         "run's own checkpoint")
    weights = {k: v.detach().float().contiguous() for k, v in checkpoint.model_weights(state).items()}
    checkpoint.check_fits(build(cfg), weights, "run dir", ckpt)
    check_finite(weights, "run dir", ckpt)
    overrides_file = run_dir / ".hydra" / "overrides.yaml"
    overrides = (read_record(overrides_file, yaml.safe_load, list, "a YAML list")
                 if overrides_file.is_file() else None)
    provenance = {
        "command": None if overrides is None else " ".join(["python -m mcd.run", *overrides]),
        "checkpoint": f"{ckpt.relative_to(run_dir)} (global step {state.get('global_step')})",
        "train": OmegaConf.to_container(cfg.train, resolve=True),
        "metrics": {k: metrics.get(k) for k in METRICS},
        **({"source_commit": source_commit} if source_commit else {}),
    }
    return write_bundle(weights, cfg, name, provenance, out_dir)


def read_record(path: Path, parse: Callable[[str], Any], kind: type, what: str) -> Any:
    """``parse`` of the text of the run record ``path``, which must be a ``kind``; ValueError naming the file
    otherwise (a ``metrics.json`` that is a JSON list ended in an AttributeError traceback, an
    ``overrides.yaml`` of random bytes in a message without the file's name)."""
    try:
        data = parse(path.read_text())
    except (ValueError, yaml.YAMLError) as err:  # UnicodeDecodeError and JSONDecodeError are ValueErrors
        raise ValueError(f"{path}: not readable ({err}); bundle a finished run of python -m mcd.run"
                         ) from None
    if not isinstance(data, kind):
        raise ValueError(f"{path}: a {type(data).__name__}, not {what}; bundle a finished run of python -m "
                         "mcd.run")
    return data


def write_bundle(weights: dict[str, torch.Tensor], cfg: DictConfig, name: str, provenance: dict[str, Any],
                 out_dir: Path = BUNDLED_DIR) -> dict[str, Any]:
    """``<out_dir>/<name>.pt`` (``weights``) and ``<name>.json`` (``provenance``, the ``.pt``'s SHA-256 and
    the model's configuration from ``cfg``, module docstring); returns the JSON."""
    config = {
        "experiment": str(cfg.get("experiment", cfg.method.name)),
        "method": OmegaConf.to_container(cfg.method, resolve=True),
        "capacity": OmegaConf.to_container(cfg.capacity, resolve=True),
        "budget": cfg.budget,
        "data": {k: _plain(cfg.data.get(k)) for k in DATA_KEYS},
    }
    pt = out_dir / f"{name}.pt"
    atomic_write(pt, lambda tmp: torch.save(weights, tmp))
    meta = {"name": name, "weights_file": pt.name, "sha256": hashlib.sha256(pt.read_bytes()).hexdigest(),
            **provenance, "config": config}
    atomic_write(out_dir / f"{name}.json", lambda tmp: tmp.write_text(json.dumps(meta, indent=1) + "\n"))
    return meta


def _plain(value: Any) -> Any:
    """``value`` with OmegaConf lists and dicts as plain ones (for the JSON)."""
    return OmegaConf.to_container(value, resolve=True) if OmegaConf.is_config(value) else value


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m mcd.bundle", description=__doc__.split("\n\n")[0])
    p.add_argument("run_dir", type=Path, help="a finished run directory of python -m mcd.run")
    p.add_argument("--name", required=True, help="the bundled checkpoint's name (e.g. F-cpu-small)")
    p.add_argument("--out", type=Path, default=BUNDLED_DIR,
                   help="folder (default: the package's mcd/bundled)")
    p.add_argument("--source-commit", help="the commit a run outside a git checkout was exported from")
    p.add_argument("--replace", action="store_true",
                   help="write over a bundle of the same name in --out (default: refuse it)")
    args = p.parse_args(argv)
    try:
        meta = bundle(args.run_dir, args.name, args.out, args.source_commit, args.replace)
    except (OSError, ValueError) as err:  # the checks' messages name the file or flag and the fix
        print(f"error: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    m = meta["metrics"]
    size = (args.out / meta["weights_file"]).stat().st_size / 1e6
    print(f"{args.out / args.name}.pt ({size:.2f} MB): "
          f"{meta['config']['experiment']}, test PSNR {m.get('psnr')} dB (input {m.get('input_psnr')} dB)")


if __name__ == "__main__":
    main()
