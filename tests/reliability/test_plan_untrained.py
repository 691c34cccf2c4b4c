"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): ``python -m mcd.plan +experiment=noisy``
(a method that is not trained: the noisy input, OIDN) ended in a RuntimeError traceback from the measured
training step ("element 0 of tensors does not require grad"). Now it prints the counts and says why nothing
was measured, exit 0, writing nothing.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import module_env, store32_overrides


@pytest.mark.slow
def test_the_plan_of_an_untrained_method_gives_its_counts_and_says_why(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "mcd.plan", "+experiment=noisy",
                           *store32_overrides(tmp_path / "data"), f"hydra.run.dir={tmp_path / 'plan'}"],
                          cwd=tmp_path, env=module_env(), capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "plan for profile test32" in proc.stdout
    assert "(not measured: method noisy is not trained (method.trainable=false)" in proc.stdout
    assert "Traceback" not in proc.stderr and not (tmp_path / "data").exists()
