"""``python -m mcd.pack data=<profile> [+experiment=X]``: pack the EXR store's training and validation frames
into the training store (:mod:`mcd.data.pack`, :mod:`mcd.data.train_store`; docs/training_store.md).

Which buffers: ``render.buffers`` as for ``python -m mcd.render`` (default ``method``: those the configured
method reads, plus ``ref`` and the uniform render at the budget). Which scenes: ``data.train_scenes`` (the
frames of their training and validation clips, :func:`mcd.data.splits.split_of`). Where, and in which
precision: ``data.train_store.dir`` and ``data.train_store.dtype``. ``python -m mcd.run`` packs by itself
when ``data.train_store.format=array``; this command does it ahead (e.g. once, before a sweep).
"""

from __future__ import annotations

from omegaconf import DictConfig

from mcd.config.compose import hydra_main


@hydra_main
def main(cfg: DictConfig) -> dict:
    """Pack the configured store's training frames (module docstring)."""
    from mcd.data.pack import pack
    from mcd.data.store_builder import StoreBuilder
    from mcd.lit.transfer import prepare
    from mcd.lit.workload import requested_buffers

    cfg, _ = prepare(cfg)
    return pack(cfg, StoreBuilder.from_cfg(cfg), requested_buffers(cfg))  # renders nothing


if __name__ == "__main__":
    main()
