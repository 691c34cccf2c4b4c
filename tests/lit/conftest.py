"""The session's 32x32 Cornell-box store (``cbox_store`` of tests/conftest.py) with 32x32 training crops."""

from pathlib import Path

import pytest

from tests.conftest import compose_cfg as compose_root
from tests.conftest import store32_overrides

#: Whole 32x32 frames as training and validation clips (the shared store's profile crops 16 / 24).
CROPS = ["data.train_crop=32", "data.val_crop=32", "train.batch_size=1"]


def compose_cfg(data_dir: Path, *overrides: str):
    """The run config of ``python -m mcd.run`` on the shared 32x32 store in ``data_dir``."""
    return compose_root(*store32_overrides(data_dir), *CROPS, *overrides)


@pytest.fixture(scope="session")
def tiny_store(cbox_store) -> Path:
    """Data dir of the rendered 32x32 Cornell-box store (every buffer, 12 frames)."""
    return cbox_store[1].data_dir
