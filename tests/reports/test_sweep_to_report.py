"""End to end on 32x32 renders: a two-job sweep (rows A and F, real Mitsuba
renders, real training steps), a failing job recorded without stopping anything, a rerun that skips the
finished jobs, F transferred to a held-out scene, the bench on the same methods, F's edge effect measured
after the run, and `python -m mcd.report` producing every table and figure with its provenance."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from mcd.config.methods import COMPONENTS
from mcd.reporting import finding
from tests.conftest import AB_SWEEP, SWEEP32, command_in_worker, copy_sweep, module_env, report_in_worker

REPO = Path(__file__).resolve().parents[2]

def _run(args: list[str], cwd: Path, returncode: int = 0) -> subprocess.CompletedProcess:
    """``python -m <module> <rest>`` (`args` is ``["-m", module, *rest]``) in `cwd`, in this process
    (:func:`tests.conftest.command_in_worker`), with the environment of a test's command."""
    assert args[0] == "-m", args
    proc = command_in_worker(args[1], args[2:], cwd, module_env())
    assert proc.returncode == returncode, f"{args}\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}"
    return proc


def _report(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``python -m mcd.report <args>`` in `cwd`, in this process (:func:`tests.conftest.report_in_worker`)."""
    proc = report_in_worker(args, cwd)
    assert proc.returncode == 0, f"{args}\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}"
    return proc


@pytest.mark.slow
def test_two_job_sweep_failure_rerun_and_report(ab_sweep, tmp_path):
    data = [f"paths.data_dir={tmp_path / 'data'}", f"paths.scenes_dir={REPO / 'scenes'}"]
    sweep = [*AB_SWEEP, f"paths.data_dir={tmp_path / 'data'}"]  # the shared sweep's command, here
    copy_sweep(ab_sweep, tmp_path)  # the two-job sweep, run once per session (tests/conftest.py)
    sweep_dir = tmp_path / "multirun" / "ablation" / "tiny"
    for exp in ("A", "F"):
        metrics = json.loads((sweep_dir / f"{exp}_spp4" / "metrics.json").read_text())
        assert metrics["experiment"] == exp and metrics["budget"] == 4

    # a failing job (KP without AS) in the same sweep: recorded, then the command exits 1 naming it
    failed = _run(
        ["-m", "mcd.run", "-m", "+sweep=ablation", "+experiment=C", "method.AS=false", *data, *SWEEP32],
        tmp_path,
        returncode=1,
    )
    assert "1 job(s) of the sweep" in failed.stderr + failed.stdout
    error = json.loads((sweep_dir / "C_spp4" / "error.json").read_text())
    assert "AS" in error["error"] and not (sweep_dir / "C_spp4" / "metrics.json").exists()

    # a rerun of the sweep skips both finished jobs
    stamps = {e: (sweep_dir / f"{e}_spp4" / "metrics.json").stat().st_mtime_ns for e in ("A", "F")}
    rerun = _run(sweep, tmp_path)
    assert (rerun.stdout + rerun.stderr).count("skip:") == 2
    assert stamps == {e: (sweep_dir / f"{e}_spp4" / "metrics.json").stat().st_mtime_ns for e in ("A", "F")}

    # transfer of the trained F to a held-out scene, as loaded and after one fine-tuning epoch
    held_out = [
        "+scene@data.scenes.cornell-box-picture=cornell-box-picture",
        "data.transfer_scenes=[cornell-box-picture]",
    ]
    _run(
        [
            "-m",
            "mcd.run",
            "-m",
            "+sweep=transfer",
            "+experiment=F",
            "transfer.finetune_epochs=0,1",
            f"transfer.init_from={sweep_dir / 'F_spp4'}",
            *data,
            *SWEEP32,
            *held_out,
        ],
        tmp_path,
    )
    transfer_dir = tmp_path / "multirun" / "transfer" / "tiny"
    ft = json.loads((transfer_dir / "F_spp4_ft1" / "metrics.json").read_text())
    assert ft["transfer"]["finetune"] and ft["scenes_test"] == ["cornell-box-picture"]

    bench_csv = tmp_path / "bench" / "bench.csv"
    _run(
        [
            "-m",
            "mcd.bench",
            "--methods",
            "A,F",
            "--sizes",
            "32x32",
            "--devices",
            "cpu",
            "--warmup",
            "1",
            "--reps",
            "2",
            "--out",
            str(bench_csv),
            "capacity=cpu",
        ],
        tmp_path,
    )

    # the edge effect of the finished F, measured after the run from the checkpoint it tested, and of the
    # transfer job tested as loaded (no checkpoint of its own: the weights it started from)
    as_loaded = transfer_dir / "F_spp4_ft0"
    edges = _run(["-m", "tools.edge_effect", str(sweep_dir / "F_spp4"), str(as_loaded), "--margin", "8"],
                 tmp_path)
    assert edges.stdout.count("edge effect") == 2
    f_edges = json.loads((sweep_dir / "F_spp4" / "edges.json").read_text())
    loaded_edges = json.loads((as_loaded / "edges.json").read_text())
    assert loaded_edges["checkpoint"] is None and loaded_edges["weights"] == str(sweep_dir / "F_spp4")
    assert loaded_edges["psnr"] == pytest.approx(json.loads((as_loaded / "metrics.json").read_text())["psnr"],
                                                 abs=0.1)
    # a run whose record does not match what is measured is refused, nothing written
    shutil.copytree(sweep_dir / "F_spp4", tmp_path / "F_copy")
    record = json.loads((tmp_path / "F_copy" / "metrics.json").read_text())
    (tmp_path / "F_copy" / "metrics.json").write_text(json.dumps({**record, "psnr": record["psnr"] + 5}))
    (tmp_path / "F_copy" / "edges.json").unlink()
    refused = _run(["-m", "tools.edge_effect", str(tmp_path / "F_copy"), str(sweep_dir / "A_spp4"),
                    "--margin", "8"], tmp_path, returncode=1)
    assert "not the weights or frames the run tested" in refused.stderr and "1 of 2 run(s)" in refused.stderr
    assert not (tmp_path / "F_copy" / "edges.json").exists()
    assert (sweep_dir / "A_spp4" / "edges.json").is_file()  # the other run was measured all the same
    (sweep_dir / "A_spp4" / "edges.json").unlink()

    _report([str(sweep_dir), str(transfer_dir), "--name", "t32", "--bench", str(bench_csv)], tmp_path)
    report = tmp_path / "reports" / "t32"
    for name in (
        "findings.json",
        "table1.md",
        "table1.csv",
        "components.md",
        "components.csv",
        "spp.csv",
        "spp.png",
        "speed_vs_error.png",
        "README.md",
        "strips/cbox.png",
        "strips/cbox_methods.png",
        "per_frame/cbox_psnr.png",
        "per_frame/per_frame.csv",
    ):
        assert (report / name).is_file() and (report / name).stat().st_size > 0, name

    comp = pd.read_csv(report / "components.csv").set_index("row")
    for exp in ("A", "F"):
        run_metrics = json.loads((sweep_dir / f"{exp}_spp4" / "metrics.json").read_text())
        assert comp.loc[exp, "PSNR"] == pytest.approx(run_metrics["psnr"])
        assert comp.loc[exp, "SSIM"] == pytest.approx(100 * run_metrics["ssim"])
    assert comp.loc["F", "PSNR paper"] == 33.39 and comp.loc["F", "KP"] == "✓"
    f_metrics = json.loads((sweep_dir / "F_spp4" / "metrics.json").read_text())
    assert comp.loc["F", "KP identity"] == pytest.approx(f_metrics["kp_identity"])
    assert 0 <= f_metrics["kp_identity"] <= 1 and pd.isna(comp.loc["A", "KP identity"])
    assert f_edges["checkpoint"] == f_metrics["checkpoint"] and len(f_edges["frames"]) >= 1
    assert comp.loc["F", "edge effect"] == pytest.approx(f_edges["edge_effect"])
    assert comp.loc["F", "map ring ratio"] == pytest.approx(f_edges["map_border_ratio"])
    assert f_edges["map_border_ratio"] > 0
    assert pd.isna(comp.loc["A", "edge effect"])  # not measured
    assert comp.loc["C", "status"].startswith("failed: ")
    t1 = pd.read_csv(report / "table1.csv").set_index("experiment")
    assert t1.loc["A", "method"] == "U-Net (row A)"  # no unet job: row A's identical network stands in
    tr = pd.read_csv(report / "transfer.csv")
    assert sorted(tr["fine-tuned"]) == [False, True] and set(tr["scene"]) == {"cornell-box-picture"}
    # speed against error: each point is its own run's model, at the run's capacity and test resolution
    speed = pd.read_csv(report / "speed_vs_error.csv").set_index("experiment")
    assert set(speed.index) == {"A", "F"}
    assert (speed["capacity"] == "cpu").all() and (speed[["width", "height"]] == 32).all().all()
    assert (speed["status"] == "ok").all() and (speed["ms_median"] > 0).all()
    assert speed.loc["F", "psnr"] == pytest.approx(f_metrics["psnr"])
    assert set(pd.read_csv(report / "speed_bench.csv")["method"]) == {"A", "F"}  # the bench's, apart

    readme = (report / "README.md").read_text()
    assert "python -m mcd.run -m +sweep=ablation +experiment=A,F" in readme  # command
    assert "Data profile(s): tiny" in readme and "capacity=cpu" in readme  # profile and config
    assert "Commit(s) of the runs: " in readme and "Commit(s) of the runs: unknown" not in readme
    assert "Device(s): CPU" in readme and "Wall time:" in readme
    assert "C_spp4" in readme and "failed" in readme  # the failed job is listed with its error
    # the claims, as data with their verdict: the paper's hold; ours cannot be checked without rows B-E
    found = {(f.kind, f.source): f for f in finding.read(report / "findings.json")}
    paper_a, paper_f = COMPONENTS["A"]["psnr"], COMPONENTS["F"]["psnr"]
    assert found["f_above_a", "paper"].verdict == "holds"
    assert found["f_above_a", "paper"].values == {"F": paper_f, "A": paper_a}
    assert found["component_rows_missing", "ours"].detail["missing"] == ["B", "C", "D", "E"]
    assert found["kp_identity_share", "ours"].values == {"F": pytest.approx(f_metrics["kp_identity"])}
    head = found["headline", "ours"]
    assert head.subjects == ("F", "A") and head.values["A"] == pytest.approx(t1.loc["A", "PSNR"])
    # what a reader of the README sees is the records' prose, in their order
    listed = [line[2:] for line in readme.split("## Findings")[1].split("## Table 1")[0].splitlines()
              if line.startswith("- ")]
    assert listed == [finding.render(f) for f in finding.read(report / "findings.json")]
    assert t1.loc["F", "rMSE"] == pytest.approx(1e3 * f_metrics["rmse"])
    assert "| SSIM paper | rMSE | GMACs |" in (report / "table1.md").read_text()

    # the report keeps its runs' records (no checkpoints, no samples) and regenerates from them alone,
    # elsewhere, once the run directories are gone
    records = report / "runs"
    assert (records / "ablation" / "tiny" / "F_spp4" / "metrics.json").is_file()
    assert (records / "ablation" / "tiny" / "F_spp4" / "edges.json").is_file()
    assert (records / "ablation" / "tiny" / "multirun.yaml").is_file()
    assert (records / "transfer" / "tiny" / "F_spp4_ft1" / "curve.csv").is_file()
    assert not list(records.rglob("*.ckpt")) and not list(records.rglob("*.exr"))
    assert "python -m mcd.report reports/t32/runs --name t32" in readme
    moved = tmp_path / "elsewhere"
    shutil.copytree(report, moved / "reports" / "t32")
    shutil.rmtree(tmp_path / "multirun")
    _report(["reports/t32/runs", "--name", "t32", "--bench", str(bench_csv)], moved)
    again = moved / "reports" / "t32"
    for name in ("components.csv", "table1.csv", "transfer.csv", "spp.csv", "curves.csv"):
        pd.testing.assert_frame_equal(
            pd.read_csv(again / name).drop(columns=["run"], errors="ignore"),
            pd.read_csv(report / name).drop(columns=["run"], errors="ignore"),
            obj=name,
        )
    again_readme = (again / "README.md").read_text()
    assert "python -m mcd.run -m +sweep=ablation +experiment=A,F" in again_readme
    assert "C_spp4" in again_readme and "failed" in again_readme
    assert (again / "runs" / "ablation" / "tiny" / "F_spp4" / "metrics.json").is_file()  # kept, not wiped
