"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): settings that would do nothing are named.

Campaign 10 left three: ``trainer.devices=0`` ended in a ZeroDivisionError traceback;
``train.sample_frames=[99]`` on a 2-frame test sequence saved no sample without a word;
``render.buffers=[]`` rendered the references without a word. Now the first is one ``error:`` line naming
the key (its rule, ``mcd.core.config_rules``), the second a warning naming the positions left out
(``mcd.config.preflight.samples_left_out``), the third an error naming the key before anything is rendered.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from mcd.config.preflight import samples_left_out
from mcd.lit.workload import requested_buffers
from tests.conftest import compose_cfg, module_env, store32_overrides


def test_no_device_is_one_error_line_naming_the_key(tmp_path):
    argv = [sys.executable, "-m", "mcd.run", *store32_overrides(tmp_path / "data"), "+experiment=noisy",
            "trainer.devices=0", f"hydra.run.dir={tmp_path / 'run'}"]
    proc = subprocess.run(argv, cwd=tmp_path, env=module_env(), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 2, (proc.stdout + proc.stderr)[-4000:]
    assert "error: trainer.devices=0: give -1 (every GPU), a count of at least 1" in proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "run").exists()


def test_sample_positions_beyond_the_test_sequence_are_named(tmp_path):
    overrides = store32_overrides(tmp_path / "data")  # 12 frames: 2 test frames
    warning = samples_left_out(compose_cfg(*overrides, "train.sample_frames=[99]"))
    assert warning == ("train.sample_frames=[99]: position(s) [99] lie beyond the 2-frame test sequence "
                       "(positions 0 to 1); none of them is saved")
    assert "saved at [0] only" in samples_left_out(compose_cfg(*overrides, "train.sample_frames=[0,3]"))
    assert samples_left_out(compose_cfg(*overrides, "train.sample_frames=[0,1]")) is None


@pytest.mark.slow
def test_an_empty_buffer_list_is_refused_before_rendering(tmp_path):
    with pytest.raises(ValueError, match=r"render\.buffers=\[\]: an empty list asks for no buffer"):
        requested_buffers(compose_cfg(*store32_overrides(tmp_path / "data"), "render.buffers=[]"))
    argv = [sys.executable, "-m", "mcd.render", *store32_overrides(tmp_path / "data"), "render.buffers=[]",
            f"hydra.run.dir={tmp_path / 'h'}"]
    proc = subprocess.run(argv, cwd=tmp_path, env=module_env(), capture_output=True, text=True, timeout=600)
    assert proc.returncode != 0 and "render.buffers=[]: an empty list" in proc.stderr
    assert not (tmp_path / "data" / "test32" / "cbox").exists()
