"""``python -m mcd.complexity`` refuses bad arguments by name before it builds a model (docs/reliability.md,
"Campaign fixes"): ``--width 0`` ended in torch's traceback ("Expected 3D or 4D (batch mode) tensor ..."); an
unknown ``--experiments``, ``--capacity`` or ``--shares`` in Hydra's MissingConfigException traceback."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import REPO


@pytest.mark.parametrize(("args", "named"), [
    (["--width", "0"], "argument --width: 0 is not an integer from 1 to 16384"),
    (["--height", "abc"], "argument --height: 'abc' is not an integer"),
    (["--experiments", "unet", "nope"], "--experiments: no experiment nope (conf/experiment: A, B"),
    (["--capacity", "../../x"], "--capacity ../../x: no such capacity profile (conf/capacity: cpu, paper)"),
    (["--shares", "big"], "--shares big: no such capacity profile"),
])
@pytest.mark.slow
def test_a_bad_argument_is_named_before_any_model_is_built(tmp_path, args, named):
    out = tmp_path / "c.csv"
    proc = subprocess.run([sys.executable, "-m", "mcd.complexity", *args, "-o", str(out)], cwd=REPO,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and named in proc.stderr, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr and not out.exists()
