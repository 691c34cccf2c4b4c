"""What ``--checkpoint`` names, loaded as weights only (docs/denoise.md, "Checkpoints").

``--checkpoint`` is a run directory of ``python -m mcd.run`` (its best checkpoint, else its last: the rule of
``transfer.init_from``, :func:`mcd.lit.transfer.checkpoint_of`), a ``.ckpt`` file of such a run, or the name
of a checkpoint bundled with the package (``mcd/bundled/<name>.pt`` + ``<name>.json``, made by ``python -m
mcd.bundle``; such a ``.pt`` elsewhere is given by its path). Every file is read with ``weights_only=True``
(:func:`mcd.lit.checkpoint.safe_load`); the model is built from the configuration the checkpoint was trained
with (a run's checkpoints carry it; a bundle's JSON holds it), and the weights must fit it exactly
(:func:`mcd.lit.checkpoint.check_fits`) and be finite (:func:`check_finite`). A bundle's JSON must parse and
hold its ``config``, and a configuration whose model would have more than :data:`mcd.denoise.work.MAX_PARAMS`
parameters is refused before it is built (counted on the ``meta`` device). ``--experiment`` / ``--capacity``
state what the user expects: a checkpoint of another method or capacity is refused, naming both.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from omegaconf import DictConfig, OmegaConf

from mcd.denoise.work import MAX_PARAMS
from mcd.lit import checkpoint

log = logging.getLogger(__name__)

if TYPE_CHECKING:  # torch is imported where used, so that --help starts fast (docs/architecture.md)
    from torch import nn

BUNDLED_DIR = Path(__file__).resolve().parents[1] / "bundled"
#: Keys a bundle's JSON ``config`` must hold (written by ``python -m mcd.bundle``).
BUNDLE_CONFIG = ("experiment", "method", "capacity", "budget", "data")
#: Methods whose first stage samples adaptively: they need a renderer (``--scene``), not frames from disk.
ADAPTIVE = ("dasr", "ntasad")


#: What to do with a checkpoint whose config is of an older schema than this version builds.
RESAVE = ("save it again on today's config schema: python -m mcd.bundle RUN_DIR --name NAME "
          "[--replace] from a run of this version, or check out the commit it records (docs/denoise.md, "
          "'Bundled checkpoints')")


def _key_paths(tree: Any, prefix: str) -> set[str]:
    """Every key of a nested mapping as a dotted path under ``prefix``."""
    paths = set()
    for key, value in tree.items():
        path = f"{prefix}.{key}"
        paths.add(path)
        if isinstance(value, dict):
            paths |= _key_paths(value, path)
    return paths


def check_schema(config: Any, source: str) -> None:
    """CheckpointError naming ``source``, the first key that differs and :data:`RESAVE` if ``config`` (a
    checkpoint's or a bundle's) is not on today's config schema: it must hold ``experiment`` (one this version
    has) and ``capacity``, and its ``method`` section exactly the keys of that experiment's today
    (:func:`mcd.config.compose.compose`)."""
    from mcd.config.compose import compose, experiment_names

    config = OmegaConf.to_container(OmegaConf.create(config), resolve=False)
    assert isinstance(config, dict)
    lacks = [k for k in ("experiment", "capacity", "method") if k not in config]
    experiment = str(config.get("experiment"))
    if lacks or experiment not in experiment_names():
        what = f"lacks '{lacks[0]}'" if lacks else f"experiment {experiment!r}, which this version lacks"
        raise checkpoint.CheckpointError(f"{source}: an older config schema ({what}); {RESAVE}")
    today = OmegaConf.to_container(compose([f"+experiment={experiment}"]).method, resolve=False)
    saved_keys, today_keys = _key_paths(config["method"], "method"), _key_paths(today, "method")
    differ = sorted(saved_keys ^ today_keys)
    if differ:
        what = "lacks" if differ[0] in today_keys else "holds"
        raise checkpoint.CheckpointError(f"{source}: an older config schema ({what} '{differ[0]}', which "
                                         f"today's +experiment={experiment} "
                                         f"{'has' if what == 'lacks' else 'does not have'}); {RESAVE}")


def bundled_names() -> list[str]:
    """Names of the checkpoints shipped with the package."""
    return sorted(p.stem for p in BUNDLED_DIR.glob("*.pt") if p.with_suffix(".json").is_file())


@dataclass
class Loaded:
    """A model with its trained weights and what is known about them."""

    model: nn.Module
    cfg: DictConfig
    source: str
    provenance: dict[str, Any] = field(default_factory=dict)

    @property
    def experiment(self) -> str:
        return str(self.cfg.get("experiment", self.cfg.method.name))

    @property
    def adaptive(self) -> bool:
        """Whether the method's first stage places samples (rows B-M, DASR, NTASAD)."""
        m = self.cfg.method
        return str(m.name) in ADAPTIVE or (str(m.name) == "two_stage" and bool(m.get("AS", False)))


def _from_run_ckpt(path: Path) -> tuple[DictConfig, dict[str, Any], dict[str, Any]]:
    state = checkpoint.safe_load(path, "--checkpoint")
    cfg = (state.get("hyper_parameters") or {}).get("cfg")
    if cfg is None:
        resolved = path.parent.parent / "resolved_config.yaml"
        if not resolved.is_file():
            raise checkpoint.CheckpointError(
                f"--checkpoint={path}: no training configuration inside and no {resolved}; give a checkpoint "
                "written by python -m mcd.run, its run directory, or a bundled name")
        cfg = OmegaConf.load(resolved)
    weights = checkpoint.model_weights(state)
    prov = {"checkpoint": str(path), "global_step": state.get("global_step")}
    cfg = OmegaConf.create(cfg)
    check_schema(cfg, f"--checkpoint={path}: its training config")
    return cfg, weights, prov


def _bundle_json(meta: Path) -> dict[str, Any]:
    """A bundle's JSON; CheckpointError naming the file if it is not JSON or has no usable ``config``."""
    try:
        provenance = json.loads(meta.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise checkpoint.CheckpointError(f"--checkpoint: {meta}: not a readable bundle JSON ({exc}); write "
                                         f"it again: {RESAVE}") from exc
    config = provenance.get("config") if isinstance(provenance, dict) else None
    method = config.get("method") if isinstance(config, dict) else None
    missing = [k for k in BUNDLE_CONFIG if not isinstance(config, dict) or k not in config]
    if missing or not isinstance(method, dict) or "name" not in method:
        raise checkpoint.CheckpointError(
            f"--checkpoint: {meta}: its 'config' lacks {', '.join(missing) or 'method.name'} (it needs "
            f"{', '.join(BUNDLE_CONFIG)}, with method.name); {RESAVE}")
    check_schema(config, f"--checkpoint: {meta}")
    return {**provenance, "config": config}


def _from_bundle(pt: Path) -> tuple[DictConfig, dict[str, Any], dict[str, Any]]:
    """A bundle's configuration, weights and provenance. The ``.pt`` must be the one its JSON was written
    for (its ``sha256``, ``mcd.bundle``): another bundle's weights of the same model, copied over it, were
    denoised with, and ``denoise.json`` stated the JSON's training for them."""
    provenance = _bundle_json(pt.with_suffix(".json"))
    recorded = provenance.get("sha256")
    if isinstance(recorded, str):
        import hashlib

        with pt.open("rb") as f:
            actual = hashlib.file_digest(f, "sha256").hexdigest()
        if actual != recorded:
            raise checkpoint.CheckpointError(
                f"--checkpoint: {pt}: its SHA-256 is {actual[:12]}..., but {pt.with_suffix('.json').name} "
                f"was written for {recorded[:12]}... (the weights were replaced, or the JSON is another "
                "bundle's); bundle the run again: python -m mcd.bundle RUN_DIR --name NAME --replace")
    weights = checkpoint.safe_load(pt, "--checkpoint")
    return OmegaConf.create(provenance["config"]), weights, provenance


def check_finite(weights: dict[str, Any], key: str, source: str | Path) -> None:
    """CheckpointError naming ``source`` and the first tensors where ``weights`` hold a NaN or an Inf (a run
    that diverged): such a network's outputs are non-finite, and the output bound (docs/method.md "Output")
    replaced every one by the render's local mean, so ``mcd-denoise`` wrote and scored a blur as the
    network's output without a word, and ``mcd.bundle`` shipped those weights with the run's test scores."""
    import torch

    bad = [k for k, v in weights.items()
           if isinstance(v, torch.Tensor) and v.is_floating_point() and not bool(torch.isfinite(v).all())]
    if bad:
        listed = ", ".join(bad[:3]) + (f" and {len(bad) - 3} more" if len(bad) > 3 else "")
        raise checkpoint.CheckpointError(
            f"{key}={source}: its weights hold NaN or Inf values ({listed}): the run that wrote them "
            "diverged, and a network with them has no output to give; take an earlier checkpoint of the run, "
            "or train it again (a lower train.lr, train.grad_clip)")


#: The parts of a checkpoint's configuration that ``mcd-denoise`` builds and feeds the model with.
READ_PARTS = ("budget", "data", "method", "capacity")


def check_values(cfg: DictConfig, source: str) -> None:
    """CheckpointError naming ``source`` and the key where a value of :data:`READ_PARTS` breaks its rule
    (:mod:`mcd.core.config_rules`, which ``mcd.run`` holds every config to before training): a bundle's JSON
    with ``data.exposure_target`` -1 or NaN denoised every frame to black and scored it 100 dB, and 0 ended
    in a ZeroDivisionError traceback."""
    from mcd.core.config_rules import ConfigError, checked, leaves

    for part in READ_PARTS:
        node = cfg.get(part)
        tree = OmegaConf.to_container(node, resolve=True) if OmegaConf.is_config(node) else node
        for key, value in leaves({part: tree}):
            try:
                checked(key, value, cfg)
            except ConfigError as err:
                raise checkpoint.CheckpointError(
                    f"--checkpoint: {source}: {err}; bundle the run again (python -m mcd.bundle RUN_DIR "
                    "--name NAME --replace), or restore the file") from None


def param_count(cfg: DictConfig) -> int:
    """Parameters of the model ``cfg`` builds, counted on PyTorch's ``meta`` device (no memory is allocated
    for them)."""
    import torch

    from mcd.models import build

    with torch.device("meta"):
        return sum(p.numel() for p in build(cfg).parameters())


def tested_checkpoint(run_dir: Path, flag: str) -> Path | None:
    """The checkpoint file of the run directory ``run_dir`` that the run itself tested: the file named by its
    ``metrics.json`` ``checkpoint``, looked up in its own ``checkpoints/`` (a run moved or copied keeps its
    name there); for a run without that record (not finished, or tested as built), its only
    ``checkpoints/best*.ckpt``, else ``last.ckpt`` (as :func:`mcd.lit.transfer.checkpoint_of`); None where
    it holds neither.

    FileNotFoundError (naming ``flag``) where the tested file is gone, or where several ``best*.ckpt`` leave
    it open which is the run's own: taking the last by name took a foreign one copied in (another run's
    best, of another experiment), whose bundle then stated this run's metrics."""
    folder = run_dir / "checkpoints"
    try:
        record = json.loads((run_dir / "metrics.json").read_text())
    except (OSError, ValueError):
        record = None
    tested = record.get("checkpoint") if isinstance(record, dict) else None
    if isinstance(tested, str) and tested:
        own = folder / Path(tested).name
        if not own.is_file():
            there = "is not a regular file" if own.exists() else "is not there"
            raise FileNotFoundError(
                f"{flag}={run_dir}: its metrics.json says it tested {tested}, and {own} {there}; "
                "give that checkpoint file itself")
        return own
    best = sorted(folder.glob("best*.ckpt"))
    if len(best) > 1:
        raise FileNotFoundError(
            f"{flag}={run_dir}: {len(best)} best checkpoints in {folder} ({', '.join(b.name for b in best)}) "
            "and no metrics.json naming the one the run tested (a run keeps one); give the .ckpt file itself")
    last = folder / "last.ckpt"
    return best[0] if best else last if last.is_file() else None


def resolve(spec: str) -> tuple[DictConfig, dict[str, Any], dict[str, Any], str]:
    """``(config, weights, provenance, source)`` of what ``--checkpoint=spec`` names (module docstring)."""
    if spec in bundled_names():
        cfg, weights, prov = _from_bundle(BUNDLED_DIR / f"{spec}.pt")
        return cfg, weights, prov, f"bundled checkpoint {spec} ({BUNDLED_DIR / spec}.pt)"
    path = Path(spec).expanduser()
    if path.suffix == ".pt" and path.is_file() and path.with_suffix(".json").is_file():
        cfg, weights, prov = _from_bundle(path)
        return cfg, weights, prov, f"bundled checkpoint {path}"
    if path.is_dir() or path.is_file():
        ckpt = path if path.is_file() else tested_checkpoint(path, "--checkpoint")
        if ckpt is None:
            raise FileNotFoundError(
                f"--checkpoint={spec}: a folder without checkpoints/best*.ckpt or checkpoints/last.ckpt; "
                "give a finished run directory of python -m mcd.run, a .ckpt file, or a bundled name "
                f"({', '.join(bundled_names()) or 'none installed'})")
        if path.is_dir() and not (path / "metrics.json").is_file():
            log.warning("--checkpoint=%s: the run has no metrics.json (it never finished, or was never "
                        "tested): %s is its checkpoint so far, untested; resume the run "
                        "(python -m mcd.run ... ckpt_path=auto) for a tested one", spec, ckpt.name)
        cfg, weights, prov = _from_run_ckpt(ckpt)
        return cfg, weights, prov, str(ckpt)
    if path.exists():  # a device (/dev/zero), a FIFO, a socket: read whole, it could never end or block
        raise ValueError(f"--checkpoint={spec}: not a regular file or a folder (a device, FIFO or "
                         "socket); give a run directory of python -m mcd.run, a .ckpt file, or one of the "
                         "bundled names")
    raise FileNotFoundError(
        f"--checkpoint={spec}: no such file or folder, and not a bundled checkpoint (bundled: "
        f"{', '.join(bundled_names()) or 'none installed'}); give a run directory of python -m mcd.run, a "
        ".ckpt file, or one of the bundled names")


def load(spec: str, experiment: str | None = None, capacity: str | None = None) -> Loaded:
    """The model of ``--checkpoint=spec`` with its weights (evaluation mode, CPU).

    ``experiment`` / ``capacity``: what the user expects (``--experiment``, ``--capacity``); a checkpoint
    of another method or capacity profile raises :class:`mcd.lit.checkpoint.CheckpointError` naming both.
    """
    from mcd.models import build

    cfg, weights, prov, source = resolve(spec)
    check_values(cfg, source)
    got = str(cfg.get("experiment", cfg.method.name))
    if experiment is not None and experiment != got:
        raise checkpoint.CheckpointError(
            f"--checkpoint={spec}: a checkpoint of experiment {got!r}, not {experiment!r}; give a checkpoint "
            f"trained with +experiment={experiment} (or drop --experiment)")
    widths = {k: OmegaConf.to_container(v, resolve=True) for k, v in (cfg.get("capacity") or {}).items()}
    if capacity is not None:
        from mcd.denoise.configs import capacity_profile

        expected = capacity_profile(capacity)
        name = str(cfg.method.name)
        key = "two_stage" if name in ("two_stage", "unet") else name
        if key in expected and widths.get(key) != expected[key]:
            raise checkpoint.CheckpointError(
                f"--checkpoint={spec}: its {key} widths are not those of capacity={capacity} "
                f"({widths.get(key)} vs {expected[key]}); give a checkpoint trained with capacity={capacity} "
                "(or drop --capacity)")
    params = param_count(cfg)
    if params > MAX_PARAMS:
        raise checkpoint.CheckpointError(
            f"--checkpoint={spec}: its configuration builds a model of {params:.3g} parameters, above the "
            f"limit of {MAX_PARAMS:.3g} (mcd.denoise.work.MAX_PARAMS); check the widths in {source}")
    model = build(cfg)
    checkpoint.check_fits(model, weights, "--checkpoint", source)
    check_finite(weights, "--checkpoint", spec if spec == source else f"{spec} ({source})")
    model.load_state_dict(weights)
    model.eval()
    return Loaded(model, cfg, source, prov)
