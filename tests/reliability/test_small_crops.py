"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): a training crop below
``data.augment.zero_pad_max`` is refused only where zero padding is on.

``mcd.run +experiment=F data.train_crop=9`` with ``data.augment.zero_pad=0`` (padding off) was refused
blaming ``data.augment.zero_pad_max=16``, a setting of an augmentation the run does not use (low). The bound
now holds where ``zero_pad > 0``, and the message says so.
"""

from __future__ import annotations

import pytest

from mcd.config.preflight import check_run
from tests.conftest import compose_cfg, store32_overrides


def test_a_small_crop_without_zero_padding_passes_and_with_it_names_both_keys(tmp_path):
    overrides = [*store32_overrides(tmp_path / "data"), "+experiment=F", "data.train_crop=9",
                 "data.val_crop=9"]
    check_run(compose_cfg(*overrides))  # zero_pad=0: nothing is padded
    with pytest.raises(ValueError, match=r"data\.augment\.zero_pad_max=16: give an integer in 1 \.\. "
                                         r"data\.train_crop \(9\), where data\.augment\.zero_pad=0\.5 pads"):
        check_run(compose_cfg(*overrides, "data.augment.zero_pad=0.5"))
