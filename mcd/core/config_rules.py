"""The rule of every numeric config key: its type, its range, whether null is allowed, and what it means
(docs/reliability.md, "One check of the config before any work"; docs/architecture.md, "Config").

:data:`RULES` is the one table (key -> :class:`Rule`), :data:`PATTERNS` the rules of key families (the
capacity profiles' widths, the scenes' camera paths). :func:`check_config` walks a composed config and
raises :class:`ConfigError` for the first value that breaks its rule, naming the key, the value, what is
expected and what to do. Every Hydra command runs it before any work (:func:`mcd.config.compose.hydra_main`),
and ``mcd.run``'s preflight again (:func:`mcd.config.preflight.check_run`); the code that reads a key may
take its checked value from :func:`checked` (the training budget, the warm-up). Checks that relate keys to
each other or to files (a crop larger than the frames, a budget without a stored render) stay in
mcd/config/preflight.py.
"""

from __future__ import annotations

import fnmatch
import math
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from omegaconf import DictConfig, ListConfig, OmegaConf

#: The largest frame side a profile may ask for (8K UHD is 7680): larger ones are typing errors that would
#: only fail after minutes of allocation.
MAX_SIDE = 16384
#: ``data.exposure_target``'s range. The scores compare display images (Reinhard, gamma 1/2.2;
#: docs/benchmark.md "Metrics"): on the Cornell box's test frames a black output scores 20 dB at a target of
#: 0.01 (the noisy input 32 dB), 55 dB at 1e-6 and 100 dB (the cap) at 1e-30, where every output and the
#: input scored 100 dB; at 10 a black output scores 2 dB, and above it the tone curve flattens every
#: highlight (the input 12.8 dB at 1e3 and at 1e6 alike). The default is 0.5.
EXPOSURE_TARGET_RANGE = (0.01, 10.0)
#: The budgets s (average spp) a run may have: the store renders a uniform image ``c{s}`` at each
#: (:data:`mcd.data.buffers.SPP_BUFFERS`), which every run is scored against.
UNIFORM_BUDGETS: tuple[int, ...] = (1, 2, 4, 8, 16, 32)


class ConfigError(ValueError):
    """A config value that breaks its rule; the message is one line naming the key."""


@dataclass(frozen=True)
class Rule:
    """What a key takes: ``kind`` ``int`` (a whole number) or ``float`` (a finite number), from ``low``
    (excluded where ``above``) to ``high`` (the value of the key ``high_key`` where given), ``null`` where
    allowed, each item of a list where ``each``, any string where ``text`` (a form the reader parses itself),
    and ``about``: what the key means or what to do. ``check`` replaces all of it for a key with its own
    parser (it raises ValueError naming the key)."""

    kind: str = "int"
    low: float | None = None
    high: float | None = None
    null: bool = False
    about: str = ""
    above: bool = False
    each: bool = False
    text: bool = False
    high_key: str | None = None
    check: Callable[[Any, DictConfig], None] | None = None

    def expected(self, cfg: DictConfig | None = None, many: bool = False) -> str:
        """What to give, e.g. ``give a whole number from 1 to 16384 or null`` (``many``: for a list)."""
        noun = "a whole number" if self.kind == "int" else "a number"
        if many:
            noun = "whole numbers" if self.kind == "int" else "numbers"
        high = self.high
        if self.high_key is not None and cfg is not None:
            high = OmegaConf.select(cfg, self.high_key, default=None)
        if self.low is not None and high is not None:
            span = f"above {_show(self.low)} and at most {_show(high)}" if self.above else \
                f"from {_show(self.low)} to {_show(high)}"
            if self.high_key:
                span += f" ({self.high_key})"
        elif self.low is not None:
            span = f"{'>' if self.above else '>='} {_show(self.low)}"
        elif high is not None:
            span = f"<= {_show(high)}"
        else:
            span = "(finite)"
        return f"give {noun} {span}" + (" or null" if self.null else "")


def _whole(low: float | None = 1, high: float | None = None, about: str = "", **kw: Any) -> Rule:
    return Rule("int", low, high, about=about, **kw)


def _number(low: float | None = 0, high: float | None = None, about: str = "", **kw: Any) -> Rule:
    return Rule("float", low, high, about=about, **kw)


def _check_budget(value: Any, cfg: DictConfig) -> None:
    """Every run is scored against the noisy uniform render at the budget (``c_s``, ``input_psnr``), which
    the store renders for the budgets of :data:`UNIFORM_BUDGETS` only."""
    choices = ", ".join(str(s) for s in UNIFORM_BUDGETS)
    try:
        budget = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"budget={value!r}: not a number; give the average samples per pixel, one of "
                          f"{choices} (e.g. budget=4)") from None
    if budget not in UNIFORM_BUDGETS:
        raise ConfigError(f"budget={value}: every run is compared with the noisy uniform render at the "
                          f"budget (c_s), which the store holds for s in {choices} only; give one of them")


def _check_shard(value: Any, cfg: DictConfig) -> None:
    parse_shard(value, OmegaConf.select(cfg, "render.shards", default=None))


def _check_devices(value: Any, cfg: DictConfig) -> None:
    """Lightning's ``devices``: -1 (every GPU), a count from 1, ``auto``, a count or index list as text
    (``"0,1"``), or a list of device indices. 0 trains on no device (it ended in a ZeroDivisionError)."""
    items = list(value) if isinstance(value, list | tuple | ListConfig) else None
    if items is not None:
        ok = bool(items) and all(isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in items)
    elif isinstance(value, str):
        text = value.strip()
        ok = text == "auto" or (re.fullmatch(r"-1|\d+|\d+(\s*,\s*\d+)+,?|\d+,", text) is not None
                                and text.strip(",") != "0")
    else:
        ok = isinstance(value, int) and not isinstance(value, bool) and (value == -1 or value >= 1)
    if not ok:
        raise ConfigError(f"trainer.devices={_show(value)}: give -1 (every GPU), a count of at least 1, "
                          "'auto', or a list of device indices such as [0, 1]; 0 devices trains on none")


_SHARD = re.compile(r"^\s*(\d+)\s*/\s*(\d+)\s*$")


def parse_shard(value: Any, shards: Any = None) -> tuple[int, int]:
    """``render.shard`` (``None``, ``"i/N"`` or ``i`` with ``render.shards=N``; 0-based) as ``(i, N)``; a
    ValueError naming the key."""
    if value is None:
        if shards not in (None, 1):
            raise ValueError(f"render.shards={shards!r} without render.shard: give render.shard=i "
                             f"(0 <= i < {shards}) too, or leave render.shards=null")
        return 0, 1
    if isinstance(value, int) and not isinstance(value, bool):
        if not isinstance(shards, int) or isinstance(shards, bool):
            raise ValueError(f"render.shard={value}: a shard number needs render.shards=N (the shard count), "
                             f"or write render.shard={value}/N")
        index, count = value, shards
    else:
        m = _SHARD.match(str(value))
        if m is None:
            raise ValueError(f"render.shard={value!r}: expected i/N with 0 <= i < N (0-based), e.g. "
                             "render.shard=0/4 .. render.shard=3/4 for four processes")
        index, count = int(m.group(1)), int(m.group(2))
        if shards is not None and shards != count:
            raise ValueError(f"render.shard={value!r} and render.shards={shards!r} disagree on the shard "
                             "count: give one of them")
    if count < 1:
        raise ValueError(f"render.shard={value!r}: the shard count N of i/N must be at least 1; give "
                         "render.shard=i/N with 0 <= i < N (0-based), e.g. render.shard=0/4")
    if index >= count:
        raise ValueError(f"render.shard={value!r}: shard {index} is out of range for {count} shards; shards "
                         f"are numbered from 0 to {count - 1} (0-based)")
    return index, count


_SPP = 1 << 20
_LIMIT = "null: no limit; training stops at the first of train.max_steps, train.max_minutes, train.epochs"

#: key -> :class:`Rule`: every numeric key of conf/ (tests/reliability/test_config_rules.py composes every
#: profile and experiment and finds none without a rule).
RULES: dict[str, Rule] = {
    "budget": Rule(about="average samples per pixel", check=_check_budget),
    "seed": _whole(0, 2**32 - 1, "the run's seed; Lightning's seed_everything takes 0 .. 2^32-1"),
    "transfer.finetune_epochs": _whole(0, about="0: test the loaded weights as they are"),
    "transfer.finetune_clips": _whole(1, about="training clips per scene for fine-tuning"),
    # render and plan
    "render.max_samples_per_pass": _whole(1, about="larger renders are split into passes"),
    "render.shard": Rule(about="i/N, 0-based", check=_check_shard),
    "render.shards": _whole(1, null=True, about="the shard count N of render.shard=i"),
    "plan.pilot_scale": _whole(1, 1024, "the pilot renders 1/pilot_scale of data.width x data.height"),
    "plan.pilot_spp": _whole(1, 4096, "samples per pixel of the pilot render"),
    "plan.pilot_frames": _whole(1, 64, "frames of the pilot render"),
    "sweep_plan.cpu_hours_limit": _number(0, about="a scaling grid planned above this many CPU-hours is "
                                          "refused without sweep_plan.allow_large=true", above=True),
    "sweep_plan.seeds_only_where.train.max_steps": _whole(1, each=True, about="budgets whose cells run every "
                                                          "seed (+sweep=scaling)"),
    "plan.step_crop": _whole(16, 4096, "the CPU training step is measured at this crop and half of it"),
    # data: the frames, the renders
    "data.width": _whole(1, MAX_SIDE, "frame width in pixels"),
    "data.height": _whole(1, MAX_SIDE, "frame height in pixels"),
    "data.segments": _whole(1, 10_000, "camera path key nodes - 1; frames = segments x frames_per_segment"),
    "data.frames_per_segment": _whole(1, 100_000, "frames = data.segments x data.frames_per_segment"),
    "data.ref_spp": _whole(1, _SPP, "samples per pixel of the reference renders"),
    "data.ref_quality.target_db": _number(0, 100, "the test references' target PSNR; null: data.ref_spp",
                                          above=True, null=True),
    "data.ref_quality.max_spp": _whole(1, _SPP, "the most samples per pixel a test reference gets"),
    "data.gbuffer_spp": _whole(1, _SPP, "samples per pixel of the G-buffers' box-filtered mean"),
    "data.max_depth": _whole(1, 1024, "path length; null: the scene file's own", null=True),
    "data.seed": _whole(0, 2**31 - 1, "every image's seed derives from it"),
    "data.exposure_target": _number(EXPOSURE_TARGET_RANGE[0], EXPOSURE_TARGET_RANGE[1],
                                    "the mean of frame 0's reference after scaling; outside it the display "
                                    "transform scores (docs/benchmark.md 'Metrics') lose the frames' errors: "
                                    "at 1e-30 every output scored 100 dB"),
    # data: the splits and clips (docs/benchmark.md)
    "data.test_fraction": _number(0, 0.9, "the first test_fraction of each sequence is the test part; the "
                                        "rest must hold validation and training clips", above=True),
    "data.val_clips": _whole(0, about="validation clips per scene, which pick the best checkpoint; 0: "
                                      "none, for a method that is not trained"),
    "data.clip_len": _whole(1, 1024, "frames per training and validation clip"),
    "data.train_clip_stride": _whole(1, high_key="data.clip_len", null=True,
                                     about="null: data.clip_len, non-overlapping clips"),
    "data.train_crop": _whole(8, MAX_SIDE, "training crop side in pixels, at most the frame's"),
    "data.train_crop_at_edge": _number(0, 1, "a probability, per axis; 0: uniform crops; docs/training.md "
                                             "'Crops at frame edges'"),
    "data.val_crop": _whole(8, MAX_SIDE, "validation crop side in pixels"),
    "data.num_workers": _whole(0, 256, "loader worker processes; 0: load in the training process"),
    "data.augment.zero_pad": _number(0, 1, "a probability; 0: off"),
    "data.augment.zero_pad_max": _whole(1, MAX_SIDE, "zero rows and columns per axis, below data.train_crop"),
    "data.augment.exposure_stops": _number(0, 20, "radiance scaled by 2^u, u uniform in [-stops, stops]"),
    # train (docs/training.md, "Budgets")
    "train.epochs": _whole(0, null=True, about=f"0: test the weights as built or loaded; {_LIMIT}"),
    "train.max_steps": _whole(1, null=True, about=_LIMIT),
    "train.max_minutes": _number(0, null=True, above=True, about=_LIMIT),
    "train.patience": _whole(1, null=True, about="validations without a gain before stopping; null: off"),
    "train.min_delta": _number(0, about="the val/psnr gain in dB that counts for train.patience"),
    "train.batch_size": _whole(1, 65536, "training clips per optimiser step"),
    "train.lr": _number(0, 10, "the learning rate; 0 leaves the weights as they are"),
    "train.lr_min": _number(0, 10, "the cosine schedule's floor"),
    "train.warmup_steps": _whole(0, about="linear learning-rate warm-up in optimiser steps; 0: none; "
                                          "docs/training.md 'Budgets'"),
    "train.weight_decay": _number(0, 1, "AdamW's weight decay; 0: none"),
    "train.grad_clip": _number(0, null=True, above=True, about="gradient norm clipping; null: off"),
    "train.limit_train_batches": _number(0, None, "a share (0 to 1] or a count of batches per epoch",
                                         above=True),
    "train.val_every": _whole(1, about="validate every n epochs, where train.val_every_steps is null"),
    "train.val_every_steps": _whole(1, null=True, about="validate every n optimiser steps"),
    "train.grad_frames": _whole(1, null=True, about="clip frames that get gradient; null: all"),
    "train.sample_frames": _whole(0, each=True, about="positions in each test sequence saved as samples"),
    # trainer, logger, loss
    "trainer.devices": Rule(about="-1: every GPU; or Lightning's forms (auto, a list)", check=_check_devices),
    "trainer.num_nodes": _whole(1, about="machines of a DDP run"),
    "trainer.log_every_n_steps": _whole(1, about="metrics logged every n optimiser steps"),
    "trainer.num_sanity_val_steps": _whole(-1, about="-1: all; 0: none"),
    "logger.flush_logs_every_n_steps": _whole(1, about="the CSV log's flush interval"),
    "loss.w_s": _number(0, about="a loss weight"),
    "loss.w_t": _number(0, about="a loss weight"),
    "loss.w_p": _number(0, about="a loss weight"),
    "loss.w_g": _number(0, about="a loss weight"),
    "loss.eps": _number(0, about="the loss's denominator floor", above=True),
    "loss.sigma": _number(0, about="the Gaussian's standard deviation in pixels", above=True),
    "loss.frame_weights": _number(0, each=True, about="a weight per clip frame"),
    "loss.perceptual_layers": _whole(0, 30, "VGG-16 feature layer indices", each=True),
    # method
    "method.denoiser_margin": _whole(0, 4096, "reflected pixels around a denoiser's input (not in training)"),
    "method.sampling.levels": _whole(1, 16, "levels of the sampling map's normalisation"),
    "method.kp.highlight": _number(0, None, "the kernel pool filters below it; null: everything",
                                   above=True, null=True),
    # capacity profiles: the exceptions to PATTERNS' widths
    "capacity.two_stage.ghost.mid_ratio": _number(0, 1, "a ghost block's share of primary channels",
                                                  above=True),
    "capacity.two_stage.pooling.hidden": _whole(0, 4096, "0: one 1x1 layer"),
}

#: Rules of key families (``fnmatch`` patterns over the dotted key; a key of :data:`RULES` comes first).
PATTERNS: dict[str, Rule] = {
    "capacity.*": _whole(1, 4096, "a layer width or count of the capacity profile, conf/capacity/",
                         each=True),
    "data.scenes.*.path.*": _number(None, None, "a camera path setting of the scene (docs/scenes.md)"),
    "data.scenes.*.seed": _whole(0, 2**31 - 1, "the procedural room's layout seed (mcd/data/procedural.py)"),
    "data.scenes.*.exposure": _number(0, None, "the scene's exposure; auto: data.exposure_target",
                                      above=True, text=True),
}


def rule_of(key: str) -> Rule | None:
    """The rule of a dotted key, or None where no rule names it."""
    if key in RULES:
        return RULES[key]
    return next((rule for pattern, rule in PATTERNS.items() if fnmatch.fnmatchcase(key, pattern)), None)


def _show(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return str(value)


def _fails(rule: Rule, value: Any, cfg: DictConfig) -> bool:
    """True where ``value`` (one item, not a list) breaks ``rule``."""
    if value is None:
        return not rule.null
    if isinstance(value, str):
        return not rule.text
    if isinstance(value, bool) or not isinstance(value, int | float):
        return True
    if not math.isfinite(value) or (rule.kind == "int" and not float(value).is_integer()):
        return True
    high = rule.high if rule.high_key is None else OmegaConf.select(cfg, rule.high_key, default=None)
    if rule.low is not None and (value <= rule.low if rule.above else value < rule.low):
        return True
    return isinstance(high, int | float) and value > high


def checked(key: str, value: Any, cfg: DictConfig | None = None) -> Any:
    """``value`` of ``key`` as it is (a whole number as an int), or :class:`ConfigError` naming the key where
    it breaks the key's rule (``cfg``: the config, for a rule that reads another key)."""
    rule = rule_of(key)
    if rule is None:
        return value
    cfg = cfg if cfg is not None else OmegaConf.create({})
    if rule.check is not None:
        try:
            rule.check(value, cfg)
        except ConfigError:
            raise
        except ValueError as err:
            raise ConfigError(str(err)) from None
        return value
    items = list(value) if rule.each and isinstance(value, list | tuple | ListConfig) else [value]
    bad = [v for v in items if _fails(rule, v, cfg)]
    if bad:
        many = isinstance(value, list | tuple | ListConfig)
        shown = _show(OmegaConf.to_container(value) if isinstance(value, ListConfig) else value)
        which = f" ({_show(bad[0])} is not)" if many else ""
        raise ConfigError(f"{key}={shown}: {rule.expected(cfg, many)}{which} ({rule.about})")
    if rule.kind == "int" and isinstance(value, float):
        return int(value)
    return value


def leaves(node: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """(dotted key, unresolved value) of every leaf of a container; a list is one leaf."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield from leaves(v, f"{prefix}.{k}" if prefix else str(k))
    else:
        yield prefix, node


def check_config(cfg: DictConfig) -> None:
    """:class:`ConfigError` for the first key of ``cfg`` (in config order) whose value breaks its rule."""
    tree = OmegaConf.to_container(cfg, resolve=False)
    for key, raw in leaves(tree):
        if key.split(".", 1)[0] == "hydra" or rule_of(key) is None:
            continue
        value = raw
        if isinstance(raw, str) and "${" in raw:
            try:
                value = OmegaConf.select(cfg, key)
            except Exception:  # an interpolation that does not resolve: its reader names it
                continue
        checked(key, value, cfg)
