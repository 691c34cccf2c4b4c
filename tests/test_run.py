"""``python -m mcd.run`` end to end on a 32x32 Cornell-box store: run directory, skip, resume, failures."""

import json
from pathlib import Path

import pandas as pd
import pytest

from mcd.core.metrics import FRAME_METRICS
from mcd.lit.run_record import REQUIRED_KEYS, job_identity
from tests.conftest import compose_cfg, mcd_run

REPO = Path(__file__).resolve().parents[1]
TINY = ["data.width=32", "data.height=32", "data.frames_per_segment=6", "data.ref_spp=16",
        "data.gbuffer_spp=2", "data.train_crop=32", "data.val_crop=32", "data.train_scenes=[cbox]",
        "data.test_scenes=[cbox]", "train.batch_size=1", "train.epochs=1", "train.sample_frames=[1]",
        "trainer.enable_progress_bar=false"]


@pytest.fixture(scope="module")
def f_run(tmp_path_factory):
    """One finished run of row F (renders the store it needs)."""
    root = tmp_path_factory.mktemp("run")
    proc = mcd_run("+experiment=F", *TINY, f"paths.data_dir={root / 'data'}", f"hydra.run.dir={root / 'F'}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    return root, proc


@pytest.mark.slow
def test_run_directory_holds_the_contract(f_run):
    root, proc = f_run
    run = root / "F"
    m = json.loads((run / "metrics.json").read_text())
    assert set(REQUIRED_KEYS) <= set(m)
    assert m["experiment"] == "F" and m["switches"] == "111111" and m["budget"] == 4
    assert m["data_profile"] == "tiny" and m["scenes_test"] == ["cbox"] and m["test_frames"] == {"cbox": 2}
    assert 0 < m["ssim"] <= 1 and 0 < m["input_ssim"] <= 1 and m["rmse"] >= 0 and m["lt"] >= 0
    assert m["macs_g"] > 0 and m["params_m"] > 0 and m["train_steps"] == 1 and m["trained"] is True
    assert m["perceptual_loss"]["on"] is False and "vgg16_weights" in m["perceptual_loss"]["reason"]
    assert len(m["commit"]) == 40 and m["device"] and m["wall_s"] > 0
    assert Path(m["config"]).is_file() and m["data"]["rendered"]["ref"] == 12
    frames = pd.read_csv(run / "frames.csv")
    assert list(frames.columns) == ["scene", "frame", *FRAME_METRICS, "kp_identity", "kp_index_std",
                                    "map_spread", "map_ring_share"]
    assert len(frames) == 2 and m["kp_index_std"] == pytest.approx(frames["kp_index_std"].mean())
    assert m["kp_identity"] == pytest.approx(frames["kp_identity"].mean())  # F has KP: one scene, its mean
    assert frames["psnr"].mean() == pytest.approx(m["psnr"])  # one scene: scene mean = overall mean
    assert frames["lt"].isna().tolist() == [True, False]
    ckpts = {p.name for p in (run / "checkpoints").iterdir()}
    assert "last.ckpt" in ckpts and any(n.startswith("best-") for n in ckpts)
    samples = {p.name for p in (run / "samples" / "cbox").iterdir()}
    for kind in ("noisy", "sampling_map", "kernel_map", "initial", "output", "reference"):
        assert {f"0001_{kind}.exr", f"0001_{kind}.png"} <= samples
    log = proc.stdout + proc.stderr
    assert "store tiny" in log and "rendered" in log  # the store's one-line report
    assert "L_p is OFF" in log


@pytest.mark.slow
def test_rerun_skips_a_finished_job(f_run):
    root, _ = f_run
    metrics = root / "F" / "metrics.json"
    before = metrics.stat().st_mtime_ns
    proc = mcd_run("+experiment=F", *TINY, f"paths.data_dir={root / 'data'}", f"hydra.run.dir={root / 'F'}")
    assert proc.returncode == 0 and "skip:" in proc.stdout + proc.stderr
    assert metrics.stat().st_mtime_ns == before


@pytest.mark.slow
def test_resume_from_a_checkpoint_continues_training(f_run):
    root, _ = f_run
    last = root / "F" / "checkpoints" / "last.ckpt"
    proc = mcd_run("+experiment=F", *TINY, "train.epochs=2", f"ckpt_path={last}",
                   f"paths.data_dir={root / 'data'}", f"hydra.run.dir={root / 'F2'}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    m = json.loads((root / "F2" / "metrics.json").read_text())
    assert m["train_steps"] == 2 and m["epochs"] == 2  # one step restored, one more trained
    assert m["data"]["rendered"] == {}  # everything reused


@pytest.mark.slow
def test_auto_resume_continues_an_interrupted_run_in_its_own_directory(f_run):
    """ckpt_path=auto (the sweeps' setting): a run dir holding checkpoints/last.ckpt but no metrics.json (a
    killed job) continues from it; a fresh dir starts from scratch."""
    import shutil

    root, _ = f_run
    killed = root / "F_killed"
    (killed / "checkpoints").mkdir(parents=True)
    shutil.copy(root / "F" / "checkpoints" / "last.ckpt", killed / "checkpoints" / "last.ckpt")
    shutil.copy(root / "F" / "job.json", killed / "job.json")  # a killed run leaves its records beside it
    proc = mcd_run("+experiment=F", *TINY, "train.epochs=2", "ckpt_path=auto",
                   f"paths.data_dir={root / 'data'}", f"hydra.run.dir={killed}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert "resuming the interrupted run" in proc.stderr + proc.stdout
    assert json.loads((killed / "metrics.json").read_text())["train_steps"] == 2  # 1 restored + 1 trained
    fresh = root / "F_fresh"
    proc = mcd_run("+experiment=F", *TINY, "train.epochs=1", "ckpt_path=auto",
                   f"paths.data_dir={root / 'data'}", f"hydra.run.dir={fresh}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert json.loads((fresh / "metrics.json").read_text())["train_steps"] == 1


@pytest.mark.slow
def test_impossible_switches_fail_before_rendering_and_write_error_json(tmp_path):
    proc = mcd_run("+experiment=A", "method.KP=true", f"paths.data_dir={tmp_path / 'data'}",
                   f"hydra.run.dir={tmp_path / 'run'}")
    assert proc.returncode != 0
    assert "method.KP=true needs method.AS=true" in proc.stderr
    err = json.loads((tmp_path / "run" / "error.json").read_text())
    assert "method.KP=true" in err["overrides"] and "needs method.AS" in err["error"]
    assert err["traceback"] and not (tmp_path / "data").exists()


@pytest.mark.slow
def test_missing_resume_checkpoint_is_a_clear_error(tmp_path):
    proc = mcd_run("+experiment=A", f"ckpt_path={tmp_path / 'nope.ckpt'}", f"paths.data_dir={tmp_path / 'd'}",
                   f"hydra.run.dir={tmp_path / 'run'}")
    assert proc.returncode != 0 and "nope.ckpt: no such checkpoint file" in proc.stderr
    assert not (tmp_path / "d").exists()  # checked before anything is rendered


@pytest.mark.slow
def test_multirun_records_a_failed_job_and_goes_on(f_run, tmp_path):
    root, _ = f_run
    sweep = tmp_path / "sweep"
    (sweep / "1").mkdir(parents=True)
    # job 1 finished earlier: F's metrics relabelled as job 1's
    metrics = json.loads((root / "F" / "metrics.json").read_text())
    metrics.update(job_identity(compose_cfg("+experiment=A", "method.FG=false", *TINY), {"data": "tiny"}))
    (sweep / "1" / "metrics.json").write_text(json.dumps(metrics))
    proc = mcd_run("-m", "+experiment=A", "method.AS=false", "method.FG=true,false", *TINY,
                   f"paths.data_dir={root / 'data'}", f"hydra.sweep.dir={sweep}",
                   "hydra.sweep.subdir=${hydra.job.num}")
    assert proc.returncode == 1, proc.stderr[-4000:]  # every job ran, then the failure is reported
    err = json.loads((sweep / "0" / "error.json").read_text())
    assert "method.fg=true" in [o.lower() for o in err["overrides"]] and "needs method.AS" in err["error"]
    assert "skip:" in proc.stdout + proc.stderr and not (sweep / "1" / "checkpoints").exists()
