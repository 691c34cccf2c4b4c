"""Campaign 8 (docs/reliability.md): a run without a training budget, or with a ``trainer.*`` key that a
``train.*`` key owns, is refused before anything is rendered. ``train.max_steps=null train.epochs=null
train.max_minutes=null`` rendered the whole store (every buffer of every frame; hours on a real profile), then
failed on "no training budget"; ``trainer.max_steps=5`` the same way. ``mcd.run`` now computes the trainer's
arguments (``mcd.lit.budget.trainer_kwargs``) before the store."""

from __future__ import annotations

import pytest

from tests.conftest import mcd_run, store32_overrides


@pytest.mark.parametrize(("overrides", "said"), [
    (["train.max_steps=null", "train.epochs=null", "train.max_minutes=null"], "no training budget"),
    (["+trainer.max_steps=5"], "trainer.max_steps is set by train.max_steps"),
])
@pytest.mark.slow
def test_a_run_without_a_budget_is_refused_before_rendering(tmp_path, overrides, said):
    proc = mcd_run("+experiment=unet", *store32_overrides(tmp_path / "data"), *overrides,
                   f"hydra.run.dir={tmp_path / 'run'}")
    assert proc.returncode != 0 and said in proc.stderr, proc.stderr[-3000:]
    assert not (tmp_path / "data" / "test32" / "cbox").exists()  # nothing rendered
