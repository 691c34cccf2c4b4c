"""``python -m mcd.bench`` checks its numbers and devices before any work (docs/reliability.md, "Campaign
fixes"): ``train --steps 0`` ran every job's build and warm-up, then failed each on a division by zero;
``speed --sizes 0x16`` wrote rows that failed to build, ``--devices tpu`` ended in torch's traceback after
measuring the CPU's matmul rate. Each is now refused by the argument parser (exit 2) naming the flag, and
nothing is written."""

from __future__ import annotations

import pytest

from mcd.bench import speed, train


@pytest.mark.parametrize(("argv", "message"), [
    (["--sizes", "0x16"], "size '0x16': width and height must be at least 1"),
    (["--devices", "cpu,tpu"], "--devices cpu,tpu: tpu is not a device this bench runs on"),
    (["--reps", "0"], "argument --reps: 0 is not an integer from 1"),
    (["--warmup", "-1"], "argument --warmup: -1 is not an integer from 0"),
])
def test_speed_refuses_a_bad_size_device_or_count(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as stop:
        speed.main(["--methods", "noisy", "--synthetic", "--out", str(tmp_path / "b" / "bench.csv"), *argv])
    assert stop.value.code == 2 and message in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize(("flag", "value"), [("--steps", "0"), ("--warmup", "-1"), ("--threads", "0")])
def test_train_refuses_a_bad_count_before_any_job(tmp_path, capsys, flag, value):
    with pytest.raises(SystemExit) as stop:
        train.main(["--methods", "unet", "--profiles", "tiny", "--out", str(tmp_path / "t.csv"), flag, value])
    assert stop.value.code == 2 and f"argument {flag}: {value} is not an integer" in capsys.readouterr().err
    assert not (tmp_path / "t.csv").exists()
