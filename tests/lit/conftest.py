"""A tiny real store (Cornell box, 32x32, 12 frames, every buffer) rendered once per test session."""

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from mcd.data import BUFFERS, Store

CONF = Path(__file__).resolve().parents[2] / "conf"
#: 12 frames: 2 test frames, one validation clip and one training clip of 5 (data.test_fraction 0.2).
TINY = ["data.width=32", "data.height=32", "data.frames_per_segment=6", "data.ref_spp=16",
        "data.gbuffer_spp=2", "data.train_crop=32", "data.val_crop=32", "data.train_scenes=[cbox]",
        "data.test_scenes=[cbox]", "train.batch_size=1"]


def compose_cfg(data_dir: Path, *overrides: str):
    """The run config of ``python -m mcd.run`` with the tiny store's overrides."""
    with initialize_config_dir(config_dir=str(CONF), version_base=None):
        return compose(config_name="config", overrides=[*TINY, f"paths.data_dir={data_dir}", *overrides])


@pytest.fixture(scope="session")
def tiny_store(tmp_path_factory) -> Path:
    """Data dir of a rendered 32x32 Cornell-box store holding every buffer."""
    data_dir = tmp_path_factory.mktemp("data")
    Store.from_cfg(compose_cfg(data_dir)).ensure(BUFFERS, progress=False)
    return data_dir
