"""Safe checkpoint loading (docs/reliability.md, "Checkpoints").

Every checkpoint the platform reads (``ckpt_path=<file>``, ``transfer.init_from=<file or run dir>``) is
opened with ``torch.load(..., weights_only=True)``: tensors and plain Python values only, so a crafted file
cannot run code while it is unpickled. A file that needs more is refused with an error naming the file and the
key. Before anything is rendered or trained, :func:`check_fits` compares the checkpoint's weights with the
model the run builds, so a checkpoint of another experiment or model profile fails at once, naming what
differs.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # torch is imported where used, so that --help starts fast (docs/architecture.md)
    import torch
    from torch import nn


class CheckpointError(ValueError):
    """A checkpoint file is unsafe, unreadable or does not fit the model of the run."""


def safe_load(path: str | Path, key: str) -> dict[str, Any]:
    """The checkpoint at ``path`` loaded with ``weights_only=True``; ``key`` is the setting that named it.

    Raises :class:`CheckpointError` when the file holds objects other than weights (unpickling them could
    run code) or is not a checkpoint at all.
    """
    import torch

    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as err:
        first = str(err).strip().splitlines()[0]
        raise CheckpointError(
            f"{key}={path}: refused: the file holds Python objects other than tensors and plain values, and "
            f"unpickling them could run code ({first}). Give a checkpoint written by python -m mcd.run "
            "(its checkpoints/*.ckpt)"
        ) from err
    except Exception as err:  # torch.load raises RuntimeError, EOFError, IndexError, ... on a foreign file
        raise CheckpointError(f"{key}={path}: not a readable checkpoint ({type(err).__name__}: {err}); give "
                              "a checkpoint written by python -m mcd.run or python -m mcd.bundle") from err
    if not isinstance(state, dict):
        raise CheckpointError(f"{key}={path}: not a checkpoint (a {type(state).__name__}, not a dict)")
    return state


def model_weights(state: dict[str, Any]) -> dict[str, torch.Tensor]:
    """The model's own weights of a Lightning checkpoint of ``DenoiseModule`` (keys ``model.*``).

    A bare state dict (no ``state_dict`` entry, no ``model.`` prefix) is returned as it is.
    """
    weights = state.get("state_dict", state)
    return {k.removeprefix("model."): v for k, v in weights.items() if k.startswith("model.")} or weights


def check_fits(model: nn.Module, weights: dict[str, torch.Tensor], key: str, path: str | Path) -> None:
    """Raise :class:`CheckpointError` unless ``weights`` has exactly ``model``'s names and shapes."""
    own = model.state_dict()
    missing = sorted(set(own) - set(weights))
    unexpected = sorted(set(weights) - set(own))
    shapes = sorted(k for k in set(own) & set(weights)
                    if tuple(getattr(weights[k], "shape", ())) != tuple(own[k].shape))
    if missing or unexpected or shapes:
        reshaped = ", ".join(f"{k} {tuple(weights[k].shape)} vs {tuple(own[k].shape)}" for k in shapes[:3])
        detail = "; ".join(part for part in (
            f"missing {missing[:5]}" if missing else "",
            f"unexpected {unexpected[:5]}" if unexpected else "",
            f"shape differs for {reshaped}" if shapes else "",
        ) if part)
        raise CheckpointError(
            f"{key}={path}: the checkpoint does not fit this model ({detail}): give a checkpoint of the same "
            "experiment, budget and model profile as this run"
        )
