"""``python -m mcd.render data=<profile>``: render what the profile's scenes need into the store.

Which buffers: ``render.buffers`` = ``method`` (default: those the configured method reads, from
``mcd.models.build(cfg).required_buffers()``, plus ``ref`` and the uniform render at the budget, as
``python -m mcd.run`` asks), ``all``, or a list such as ``[c4,ref]``. Which scenes: those the same
``mcd.run`` command would read (with ``transfer.init_from`` set, the transfer scenes only); scenes may be
given by path (``data.test_scenes=[path/to/scene.xml]``, docs/scenes.md).
``--force`` (or ``render.force=true``) re-renders them; ``render.verify=true`` checks every checksum and re-
renders damaged files; ``render.variant`` picks the Mitsuba variant (default ``auto``: CUDA, else LLVM, else
scalar; logged). The store lives in ``paths.data_dir`` (env ``MCD_DATA_DIR``); Hydra's ``hydra.run.dir`` holds
the log. Rendering resumes where an interrupted run stopped.

Parts of a profile (docs/scale.md, "Render in shards"; :mod:`mcd.data.shards`): ``render.shard=i/N``
(0-based; or ``render.shard=i render.shards=N``) renders the i-th of N disjoint shards of the (scene, frame)
units; ``render.scenes=[a,b]`` and ``render.frames=a:b`` (0-based, b excluded) narrow the units first. N
processes or machines may render their shards into one store at once, e.g. as a Hydra multirun:
``python -m mcd.render -m data=paper render.shards=64 'render.shard=range(0,64)' hydra/launcher=slurm``
(``hydra/launcher=joblib`` on one machine).
"""

from __future__ import annotations

import logging
import sys

from omegaconf import DictConfig

from mcd.config.compose import hydra_main
from mcd.data.shards import Selection
from mcd.lit.workload import requested_buffers

log = logging.getLogger("mcd.render")


@hydra_main
def main(cfg: DictConfig) -> dict:
    from mcd.data.store_builder import StoreBuilder  # here, not above: a fast --help (docs/architecture.md)
    from mcd.lit.transfer import prepare
    from mcd.lit.workload import announce

    cfg, _ = prepare(cfg)  # a transfer run reads its held-out scenes only
    store = StoreBuilder.from_cfg(cfg)
    selection = Selection.from_render_cfg(cfg.render, store.scene_names, store.n_frames)
    buffers = requested_buffers(cfg)
    units = sum(map(len, selection.units(store.scene_names, store.n_frames).values()))
    announce(cfg, "mcd.render", buffers, train=False, share=units / (len(store.scene_names) * store.n_frames))
    log.info("rendering profile %s into %s: buffers %s; %s", store.profile, store.root,
             ",".join(sorted(buffers)), selection.describe())
    report = store.ensure(buffers, selection=selection)
    for scene, q in report["reference"].items():
        if q["test_psnr_db"] is not None:
            log.info("reference quality %s: test frames %d spp, estimated %.2f dB (lowest frame %.2f; "
                     "target %g, pilot at %d spp %.2f dB); training frames %d spp", scene, q["test_spp"],
                     q["test_psnr_db"], q["test_psnr_min_db"], q["target_db"], q["train_spp"], q["pilot_db"],
                     q["train_spp"])
    return report


def _argv_flags() -> None:
    """Accept ``--force`` as a shorthand for ``render.force=true``."""
    if "--force" in sys.argv:
        sys.argv = [a for a in sys.argv if a != "--force"] + ["render.force=true"]


if __name__ == "__main__":
    _argv_flags()
    main()
