"""Checks of a run's config that must fail before anything is rendered or trained (docs/reliability.md).

:func:`check_run` refuses a value outside its key's rule (mcd/core/config_rules.py, the one table of them: a
budget that is not a number or has no stored uniform render, a warm-up that is not a step count, ...),
images smaller than the SSIM window, training crops the frames cannot hold, a training-clip stride outside
1 to ``data.clip_len``, a malformed ``data.augment`` block and a diagnostic switch on a method without
that input (:func:`check_diagnostics`); :func:`check_motion` refuses a run that reads the motion buffer where
the training data cannot hold it, :func:`check_train_store` a packed training store of another config or
without a buffer of the run (docs/reliability.md); the store checks every scene file before its first
render (:meth:`mcd.data.store_builder.StoreBuilder.ensure`), and the model its own budget rule when it is
built (row F's adaptive sampling needs ``1 < s``; a method without it reads ``c_s``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable

from omegaconf import DictConfig

from mcd.core.config_rules import check_config, checked
from mcd.core.metrics import SSIM_WINDOW
from mcd.data.splits import check_crops, clip_stride, split_of


def check_budget(cfg: DictConfig) -> float:
    """``cfg.budget`` as a number, if every method can be tested at it; else ValueError saying what to give
    (the rule of ``budget`` in mcd/core/config_rules.py: a budget with a stored uniform render ``c_s``)."""
    return float(checked("budget", cfg.get("budget")))


def check_scenes(cfg: DictConfig) -> None:
    """ValueError naming the key when a run has no scene to test on (``data.test_scenes`` empty: it trained
    to its budget, then failed writing ``metrics.json``), or a method that trains has none to train on
    (``data.train_scenes`` empty: it rendered the test scenes, then failed in Lightning). A transfer job
    takes both from ``data.transfer_scenes`` (:func:`mcd.lit.transfer.prepare`, which checks them)."""
    transfer = cfg.get("transfer")
    if transfer is not None and transfer.get("init_from"):
        return
    d = cfg.data
    if not list(d.get("test_scenes") or []):
        raise ValueError(f"data.test_scenes is empty (profile {d.get('name')}): a run is scored on its test "
                         "scenes; name at least one, e.g. 'data.test_scenes=[cbox]'")
    if cfg.method.get("trainable", True) and not list(d.get("train_scenes") or []):
        raise ValueError(f"data.train_scenes is empty (profile {d.get('name')}) and method "
                         f"{cfg.method.name} trains: name at least one, e.g. 'data.train_scenes=[cbox]', or "
                         "test an untrained method (+experiment=noisy)")


def check_image_size(cfg: DictConfig) -> None:
    """ValueError unless ``data.width`` and ``data.height`` are at least the SSIM window (tested whole)."""
    w, h = int(cfg.data.width), int(cfg.data.height)
    if min(w, h) < SSIM_WINDOW:
        raise ValueError(f"data.width={w} data.height={h}: test frames are scored by SSIM, whose window "
                         f"needs at least {SSIM_WINDOW}x{SSIM_WINDOW} pixels; give data.width and "
                         f"data.height >= {SSIM_WINDOW}")


def check_clip_stride(cfg: DictConfig) -> None:
    """ValueError naming the key unless ``data.train_clip_stride`` is null or 1 to ``data.clip_len``
    (:func:`mcd.data.splits.clip_stride`)."""
    clip_stride(int(cfg.data.clip_len), cfg.data.get("train_clip_stride"))


def check_split(cfg: DictConfig) -> None:
    """ValueError (:func:`mcd.data.splits.split_frames`: the frames left after the test frames and what to
    raise or lower) unless a sequence of the profile (``data.segments`` x ``data.frames_per_segment``)
    holds the test frames, ``data.val_clips`` validation clips and one training clip, where the run has
    training or test scenes: the datamodule splits each of them so, after every scene was rendered (with
    ``data=medium`` and 12-frame sequences, all four of its scenes rendered before the error)."""
    d = cfg.data
    if not (list(d.get("train_scenes") or []) or list(d.get("test_scenes") or [])):
        return
    split_of(int(d.segments) * int(d.frames_per_segment), d)


def check_augment(cfg: DictConfig, buffers: Iterable[str] | None = None) -> None:
    """ValueError naming the key unless ``data.augment`` holds known keys with valid values, and values the
    run's ``buffers`` (where given) can take (:meth:`mcd.data.augment.Augment.from_cfg`)."""
    from mcd.data.augment import Augment

    Augment.from_cfg(cfg.data, buffers=buffers)


def check_warmup(cfg: DictConfig) -> int:
    """``train.warmup_steps`` as an int (absent: 0), or ValueError naming the key unless it is a whole
    number >= 0 (:func:`mcd.lit.module.warmup_factor`)."""
    return int(checked("train.warmup_steps", cfg.train.get("warmup_steps", 0)))


#: Diagnostic switches (docs/method.md "Diagnostics", docs/baselines.md "NTASAD's diagnostics"): key of
#: ``method`` -> (the ``method.name``\ s that have the input it changes, what that input is).
DIAGNOSTICS = {
    "warp": (("ntasad",), "the previous output fed back, warped by the motion vectors"),
    "previous_output": (("ntasad",), "the previous output fed back"),
    "warp_previous": (("two_stage", "unet"), "F_d's previous output warped by the motion vectors (rows A-M)"),
}


def check_diagnostics(cfg: DictConfig) -> None:
    """ValueError naming the key unless each diagnostic switch of :data:`DIAGNOSTICS` present in ``method``
    belongs to the configured method and is a boolean."""
    name = str(cfg.method.name)
    for key, (owners, what) in DIAGNOSTICS.items():
        if key not in cfg.method:
            continue
        if name not in owners:
            raise ValueError(f"method.{key}: method {name} has no such input; the switch changes {what}, "
                             f"so it applies to method.name={' or '.join(owners)} only. Remove method.{key}.")
        if not isinstance(cfg.method[key], bool):
            raise ValueError(f"method.{key}={cfg.method[key]!r}: give true or false")


def check_motion(cfg: DictConfig, buffers: Iterable[str]) -> None:
    """ValueError (before anything is rendered) when the run reads the ``motion`` buffer, as
    ``method.warp_previous`` and NTASAD do, and its packed training store (``data.train_store.format=array``)
    was packed without it; names the file and what to do. (Time-reversed clips with motion are
    :func:`check_augment`'s.)"""
    if "motion" not in set(buffers):
        return
    from mcd.data.train_store import TrainStoreSettings  # here: it imports torch, which --help must not

    settings = TrainStoreSettings.from_cfg(cfg)
    meta = settings.dir / "store.json"
    if settings.format != "array" or not meta.is_file():
        return
    packed = list(json.loads(meta.read_text()).get("channels", {}))
    if "motion" not in packed:
        why = ("method.warp_previous=true reads" if cfg.method.get("warp_previous") else
               f"method {cfg.method.name} reads")
        raise ValueError(f"{why} the motion buffer, and the training store {settings.dir} holds {packed} "
                         f"only ({meta}): give another data.train_store.dir, or delete {settings.dir} "
                         "and let mcd.run pack it again with the motion buffer")


def check_train_store(cfg: DictConfig, buffers: Iterable[str], pack_command: str) -> None:
    """TrainStoreError (before anything is rendered) when the run trains from a packed training store
    (``data.train_store.format=array``) whose ``store.json`` says it was packed with another dtype, frame
    size or profile, or without a buffer of ``buffers`` (:func:`mcd.data.train_store.check_meta`: the
    message names the store, the key or the buffers it lacks, and the fix). A store with no ``store.json``
    is not packed yet, and the run packs it (docs/training_store.md); ``pack_command`` packs the store (a
    corrupt ``store.json`` is named with it, :func:`mcd.data.train_store.read_meta`)."""
    from mcd.data.train_store import TrainStoreSettings, check_meta, read_meta

    settings = TrainStoreSettings.from_cfg(cfg)
    meta_path = settings.dir / "store.json"
    if settings.format != "array" or not meta_path.is_file():
        return
    check_meta(read_meta(meta_path, pack_command), settings, cfg.data, buffers, meta_path)


def check_batches(cfg: DictConfig) -> None:
    """ValueError naming ``train.limit_train_batches`` where its share of an epoch's batches is no batch:
    Lightning takes ``int(batches x share)`` and refused 0.5 of one batch ("0.5 * 1 < 1") when training
    started, after the store was rendered. The batches per epoch are the training clips of the split
    (:func:`mcd.data.splits.split_of`, per training scene) over ``train.batch_size`` and the ranks
    (``trainer.devices`` x ``trainer.num_nodes``, where a count). A method that is not trained, or a run
    without training scenes, is not checked."""
    limit = cfg.train.get("limit_train_batches", 1.0)
    d = cfg.data
    if not isinstance(limit, float) or limit >= 1.0 or not bool(cfg.method.get("trainable", True)) \
            or not list(d.get("train_scenes") or []):
        return
    try:
        clips = len(split_of(int(d.segments) * int(d.frames_per_segment), d)["train"]) * len(d.train_scenes)
    except ValueError:  # check_split names it
        return
    devices = cfg.trainer.get("devices", 1)
    ranks = (int(devices) if str(devices).isdigit() else 1) * int(cfg.trainer.get("num_nodes", 1) or 1)
    batches = math.ceil(clips / max(ranks, 1) / int(cfg.train.batch_size))
    if int(batches * limit) < 1:
        raise ValueError(f"train.limit_train_batches={limit}: that share of the {batches} training batch(es) "
                         f"per epoch ({clips} clip(s), train.batch_size={int(cfg.train.batch_size)}"
                         f"{f', {ranks} ranks' if ranks > 1 else ''}) is no batch; give a share of at least "
                         f"{1 / batches:.3g}, or a count of batches (an integer, e.g. 1)")


def samples_left_out(cfg: DictConfig) -> str | None:
    """A warning naming ``train.sample_frames`` where some of its positions lie beyond the test sequence
    (no sample is saved for them; ``train.sample_frames=[99]`` on a 2-frame test sequence saved none without
    a word), else None. Not an error: a train profile's positions (``[0, 3]``) serve profiles of every
    length."""
    positions = sorted({int(p) for p in cfg.train.get("sample_frames") or []})
    d = cfg.data
    if not positions or not list(d.get("test_scenes") or []):
        return None
    try:
        n_test = len(split_of(int(d.segments) * int(d.frames_per_segment), d)["test"][0])
    except ValueError:  # check_split names it
        return None
    beyond = [p for p in positions if p >= n_test]
    if not beyond:
        return None
    saved = "none of them is saved" if len(beyond) == len(positions) else \
        f"samples are saved at {[p for p in positions if p < n_test]} only"
    return (f"train.sample_frames={positions}: position(s) {beyond} lie beyond the {n_test}-frame test "
            f"sequence (positions 0 to {n_test - 1}); {saved}")


def check_run(cfg: DictConfig) -> None:
    """Every key's own rule (:func:`mcd.core.config_rules.check_config`), then every check of this module, in
    the order a user would fix them."""
    check_config(cfg)
    check_scenes(cfg)
    check_diagnostics(cfg)
    check_budget(cfg)
    check_image_size(cfg)
    check_crops(cfg)
    check_clip_stride(cfg)
    check_split(cfg)
    check_batches(cfg)
    check_augment(cfg)
    check_warmup(cfg)
