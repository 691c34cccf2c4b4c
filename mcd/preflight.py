"""Checks of a run's config that must fail before anything is rendered or trained (docs/reliability.md).

:func:`check_run` refuses a budget that is not a number or has no stored uniform render, images smaller
than the SSIM window, training crops the frames cannot hold, a training-clip stride outside 1 to
``data.clip_len``, a malformed ``data.augment`` block and a warm-up that is not a step count; the
store checks every scene file before its first render (:meth:`mcd.data.store_builder.StoreBuilder.ensure`),
and the model its own budget rule when it is built (row F's adaptive sampling needs ``1 < s``; a method
without it reads ``c_s``).
"""

from __future__ import annotations

from collections.abc import Iterable

from omegaconf import DictConfig

from mcd.data.buffers import UNIFORM_BUDGETS
from mcd.data.splits import clip_stride
from mcd.metrics import SSIM_WINDOW


def check_budget(cfg: DictConfig) -> float:
    """``cfg.budget`` as a number, if every method can be tested at it; else ValueError saying what to give.

    Every run is scored against the noisy uniform render at the budget (``c_s``, ``input_psnr``), which the
    store renders for s in 1, 2, 4, 8, 16, 32 only.
    """
    raw = cfg.get("budget")
    choices = ", ".join(str(s) for s in UNIFORM_BUDGETS)
    try:
        budget = float(raw)
    except (TypeError, ValueError):
        raise ValueError(f"budget={raw!r}: not a number; give the average samples per pixel, one of "
                         f"{choices} (e.g. budget=4)") from None
    if budget not in UNIFORM_BUDGETS:
        raise ValueError(f"budget={raw}: every run is compared with the noisy uniform render at the budget "
                         f"(c_s), which the store holds for s in {choices} only; give one of them")
    return budget


def check_image_size(cfg: DictConfig) -> None:
    """ValueError unless ``data.width`` and ``data.height`` are at least the SSIM window (tested whole)."""
    w, h = int(cfg.data.width), int(cfg.data.height)
    if min(w, h) < SSIM_WINDOW:
        raise ValueError(f"data.width={w} data.height={h}: test frames are scored by SSIM, whose window "
                         f"needs at least {SSIM_WINDOW}x{SSIM_WINDOW} pixels; give data.width and "
                         f"data.height >= {SSIM_WINDOW}")


def check_crops(cfg: DictConfig) -> None:
    """ValueError unless ``data.train_crop`` fits the frames and ``data.train_crop_at_edge`` is a
    probability."""
    d = cfg.data
    crop, w, h = int(d.train_crop), int(d.width), int(d.height)
    if crop > min(w, h):
        raise ValueError(f"data.train_crop={crop} is larger than the {w}x{h} frames of profile {d.name}: "
                         f"give data.train_crop <= {min(w, h)}")
    at_edge = float(d.get("train_crop_at_edge", 0.0))
    if not 0.0 <= at_edge <= 1.0:
        raise ValueError(f"data.train_crop_at_edge={at_edge} is a probability: give a value in [0, 1] (0: "
                         f"uniform crops; docs/training.md, 'Crops at frame edges')")


def check_clip_stride(cfg: DictConfig) -> None:
    """ValueError naming the key unless ``data.train_clip_stride`` is null or 1 to ``data.clip_len``
    (:func:`mcd.data.splits.clip_stride`)."""
    clip_stride(int(cfg.data.clip_len), cfg.data.get("train_clip_stride"))


def check_augment(cfg: DictConfig, buffers: Iterable[str] | None = None) -> None:
    """ValueError naming the key unless ``data.augment`` holds known keys with valid values, and values the
    run's ``buffers`` (where given) can take (:meth:`mcd.data.augment.Augment.from_cfg`)."""
    from mcd.data.augment import Augment

    Augment.from_cfg(cfg.data, buffers=buffers)


def check_warmup(cfg: DictConfig) -> int:
    """``train.warmup_steps`` as an int (absent: 0), or ValueError naming the key unless it is a whole
    number >= 0 (:func:`mcd.lit.module.warmup_factor`)."""
    raw = cfg.train.get("warmup_steps", 0)
    if isinstance(raw, bool) or not isinstance(raw, int) or raw < 0:
        raise ValueError(f"train.warmup_steps={raw!r}: give a whole number of optimiser steps >= 0 "
                         "(0: no warm-up; docs/training.md 'Budgets')")
    return raw


def check_run(cfg: DictConfig) -> None:
    """Every check of this module, in the order a user would fix them."""
    check_budget(cfg)
    check_image_size(cfg)
    check_crops(cfg)
    check_clip_stride(cfg)
    check_augment(cfg)
    check_warmup(cfg)
