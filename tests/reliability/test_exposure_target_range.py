"""Campaign 13 (docs/reliability.md, "Campaign fixes"; campaign 12's left medium): ``data.exposure_target``
has a range in which the display-image scores still see the frames' errors.

``python -m mcd.run ... data.exposure_target=1e-30`` made every frame display black: the output and the noisy
input both scored 100 dB, exit 0; at ``1e6`` the tone curve flattened every highlight and the output scored
as the input (13.22 dB both). Now the config check (mcd/core/config_rules.py, ``EXPOSURE_TARGET_RANGE``,
0.01 to 10) refuses such a value before anything is rendered, naming the key.
"""

from __future__ import annotations

import pytest

from mcd.core.config_rules import ConfigError, checked
from tests.reliability.test_config_rules import _assert_refused, _command


@pytest.mark.parametrize("value", ["1e-30", "1e6"])
def test_an_exposure_target_that_leaves_no_error_to_score_is_refused(tmp_path, value):
    line = _assert_refused(tmp_path, _command(tmp_path, "mcd.run", "+experiment=unet",
                                              f"data.exposure_target={value}"), "data.exposure_target")
    assert "display" in line, line


def test_the_range_holds_the_default_and_its_ends():
    for value in (0.01, 0.25, 0.5, 10.0):
        assert checked("data.exposure_target", value) == value
    for value in (0.009, 10.5, 0.0, -1.0):
        with pytest.raises(ConfigError, match="data.exposure_target"):
            checked("data.exposure_target", value)
