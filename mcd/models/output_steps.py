"""The output steps after a method's network (docs/method.md "Output", docs/baselines.md "Output"; not in
the paper), the same for every method that sets them: ``method.mean_match``
(:func:`mcd.models.mean_match.match_frame_mean`), then ``method.output_bound``
(:func:`mcd.models.output_bound.clamp_output`; outside training only), then ``method.pass_misses``
(:func:`mcd.models.misses.pass_misses`), all against the render the method denoised
(:func:`denoised_render`). :func:`mcd.models.registry.build` adds them to every model it builds as one
forward hook, so a model's parameters and checkpoints are the same with them and without them.
"""

from __future__ import annotations

from typing import Any

from omegaconf import DictConfig
from torch import Tensor, nn

from mcd.core.stages import stage
from mcd.data.buffers import uniform_buffer
from mcd.models.mean_match import match_frame_mean
from mcd.models.misses import pass_misses
from mcd.models.output_bound import clamp_output


def current_frame(buffer: Tensor, past: int) -> Tensor:
    """``buffer`` ``[B, C, H, W]`` as it is, or frame ``past`` of a windowed ``[B, T, C, H, W]`` one."""
    return buffer[:, past] if buffer.dim() == 5 else buffer


def denoised_render(out: dict[str, Tensor], x: dict[str, Any], budget: float, past: int) -> Tensor:
    """The render a method denoised, ``[B, 3, H, W]``: its output's ``adaptive`` image when it has one (the
    samples an adaptive method paid for: rows B-M, DASR, NTASAD), else the current frame of the uniform
    render ``c{budget}`` of its input ``x`` (row A and the uniform baselines; index ``past`` of a windowed
    input)."""
    render = out.get("adaptive")
    return render if render is not None else current_frame(x[uniform_buffer(budget)], past)


def mean_match_mode(method: DictConfig) -> bool | str:
    """``method.mean_match`` (default ``false``), checked: ``true`` (in training, validation and test: the
    network learns through the gain), ``test`` (in validation and test only: the network trains without it) or
    ``false`` (never); ValueError naming the key otherwise."""
    value = method.get("mean_match", False)
    if isinstance(value, bool) or value == "test":
        return value
    raise ValueError(f"method.mean_match={value!r}: use true (training and test), test (validation and test "
                     "only) or false (docs/method.md \"Output\")")


def output_bound_on(method: DictConfig) -> bool:
    """``method.output_bound``, checked: ``true`` or ``false``; when the method's file does not set it (the
    methods without weights: OIDN, the noisy input), ``true`` for a method with weights (``method.trainable``,
    default true) and ``false`` for one without. ValueError naming the key otherwise."""
    value = method.get("output_bound", bool(method.get("trainable", True)))
    if isinstance(value, bool):
        return value
    raise ValueError(f"method.output_bound={value!r}: use true (outside training, the default of every "
                     "learned method) or false (docs/method.md \"Output\")")


def attach_output_steps(module: nn.Module, method: DictConfig, budget: float) -> nn.Module:
    """``module`` (a method's model: ``forward(x) -> {"output", ...}``) with the output steps ``method``
    sets, applied to its ``output`` by one forward hook; ``module`` as it is when it sets none. With
    ``method.mean_match=test`` the hook skips the mean match while ``module`` is in training mode; the
    output bound always does (a clamp would zero the gradients of the pixels it holds:
    mcd/models/output_bound.py)."""
    mean, misses = mean_match_mode(method), bool(method.get("pass_misses", False))
    bound = output_bound_on(method)
    if not (mean or misses or bound):
        return module
    past = int(getattr(module, "window", (0, 0))[0])

    def hook(model: nn.Module, args: tuple[Any, ...], out: dict[str, Tensor]) -> dict[str, Tensor]:
        with stage("output steps"):
            x = args[0]
            render = denoised_render(out, x, budget, past)
            if mean is True or (mean == "test" and not model.training):
                out["output"] = match_frame_mean(out["output"], render)
            if bound and not model.training:
                out["output"] = clamp_output(out["output"], render)
            if misses:
                out["output"] = pass_misses(out["output"], render, current_frame(x["normal"], past))
        return out

    module.register_forward_hook(hook)
    return module
