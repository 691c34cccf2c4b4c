"""The baselines of the paper's Table 1 (docs/baselines.md; docs/benchmark.md "Experiments"), each registered
in
:mod:`mcd.models.registry` under its ``method.name``: ``unet`` (= component row A), ``rae``, ``fastdvdnet``,
``dasr``, ``ntasad``, and the parameter-free ``oidn`` (Intel Open Image Denoise) and ``noisy`` (the input)."""

from mcd.models.baselines import dasr, fastdvdnet, noisy, ntasad, oidn, rae, unet

__all__ = ["dasr", "fastdvdnet", "noisy", "ntasad", "oidn", "rae", "unet"]
