"""Campaign 8 (docs/reliability.md, "Campaign 8, part 2"): ``python -m mcd.report`` on run records whose
bytes were crafted. A scene name in ``frames.csv`` wrote the per-frame plot outside the report folder; a
record field of another type (``"budget": "abc"``, ``method: 5``, a garbage ``resolved_config.yaml`` or
``.hydra/overrides.yaml``) ended the whole report in a traceback; a folder of the output root whose README.md
is not UTF-8 ended the index in one, after the report was written; runs of one profile name made from other
data (or of another capacity) were compared in findings, and the strips crashed on their other frame size.
The command runs for real."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from mcd.data.exr import write_exr
from tests.conftest import report_in_worker
from tests.reliability.test_report_inputs import GARBAGE, _job, _report, _report_process


def _sweep(tmp_path: Path) -> tuple[Path, Path]:
    """A sweep of two finished jobs (F and the U-Net at 4 spp); returns it and the U-Net's run."""
    sweep = tmp_path / "multirun"
    _job(sweep, "F_spp4", {"psnr": 30.5, "ssim": 0.9, "experiment": "F", "budget": 4})
    return sweep, _job(sweep, "unet_spp4", {"psnr": 29.0, "ssim": 0.8, "experiment": "unet", "budget": 4})


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["../../../outside/pwn", "/ABS/pwn"])
def test_a_scene_name_from_frames_csv_never_writes_outside_the_report(tmp_path, scene):
    sweep, bad = _sweep(tmp_path)
    outside = tmp_path / "outside"
    outside.mkdir()
    scene = scene.replace("/ABS", str(outside))
    frames = bad / "frames.csv"
    frames.write_text(frames.read_text().replace("cbox", scene))
    proc = _report(tmp_path, str(sweep))
    assert list(outside.iterdir()) == [], "the per-frame plot was written outside the report folder"
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    frames_csv = bad.resolve() / "frames.csv"
    assert f"error: {frames_csv} is corrupt (a scene that is not a plain name" in proc.stderr, proc.stderr
    report = tmp_path / "reports" / "t"
    assert "2 found, 1 finished, 1 failed" in (report / "README.md").read_text()
    assert sorted(p.name for p in (report / "per_frame").glob("*.png")) == ["cbox_psnr.png"]


@pytest.mark.parametrize(("file", "text", "why"), [
    ("metrics.json", {"budget": "abc"}, "a field of another type: budget='abc'"),
    ("metrics.json", {"segments": [1, 2]}, "a field of another type: segments[0]=1, segments[1]=2"),
    ("metrics.json", {"wall_s": "x", "train_steps": "many"}, "train_steps='many', wall_s='x'"),
    ("metrics.json", {"seed": 1e400}, "a field of another type: seed=inf"),
    (".hydra/config.yaml", "experiment: unet\nbudget: 4\nmethod: 5\n", "a value of another type: method=5"),
    (".hydra/config.yaml", "experiment: unet\nbudget: 4\ndata: x\n", "a value of another type: data='x'"),
    ("resolved_config.yaml", GARBAGE, "is corrupt (not a readable Hydra record"),
    (".hydra/overrides.yaml", GARBAGE, "is corrupt (not a readable Hydra record"),
    ("frames.csv", "scene,frame,psnr,ssim\ncbox,0,30.0,zz\ncbox,1,31.0,0.9\n",
     "(a ssim that is not a number)"),
])
@pytest.mark.slow
def test_a_record_field_of_another_type_fails_that_run_and_the_report_goes_on(tmp_path, file, text, why):
    sweep, bad = _sweep(tmp_path)
    (sweep / "multirun.yaml").write_text("hydra:\n  overrides:\n    task: [+experiment=F,unet]\n")
    path = bad / file
    if isinstance(text, dict):
        path.write_text(json.dumps({**json.loads(path.read_text()), **text}))
    elif isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    proc = _report(tmp_path, str(sweep))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    assert f"error: {bad.resolve() / file} is corrupt" in proc.stderr and why in proc.stderr, proc.stderr
    readme = (tmp_path / "reports" / "t" / "README.md").read_text()
    assert "2 found, 1 finished, 1 failed" in readme and "unet_spp4" in readme


def test_a_folder_whose_readme_is_not_utf8_leaves_the_index_whole(tmp_path):
    sweep, _ = _sweep(tmp_path)
    other = tmp_path / "reports" / "other"
    other.mkdir(parents=True)
    (other / "README.md").write_bytes(b"\xff\xfe# not UTF-8 \x83\n")
    proc = _report(tmp_path, str(sweep))
    assert proc.returncode == 0, proc.stderr
    index = (tmp_path / "reports" / "README.md").read_text()
    assert "| t |" in index and "| other |" in index
    assert (other / "README.md").read_bytes() == b"\xff\xfe# not UTF-8 \x83\n"


@pytest.mark.parametrize("entry", ["runs", "table1.csv", "strips/cbox.png"])
def test_a_link_where_the_report_writes_is_refused_before_anything_is_written(tmp_path, entry):
    sweep, _ = _sweep(tmp_path)
    report = tmp_path / "reports" / "t"
    target = tmp_path / "elsewhere"
    target.mkdir()
    (target / "keep.txt").write_text("the user's\n")
    link = report / entry
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(target if entry == "runs" else target / "keep.txt")
    proc = _report(tmp_path, str(sweep))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    to = target if entry == "runs" else target / "keep.txt"
    assert proc.stderr.strip() == (f"error: {link}: a link where the report writes (to {to}); a report "
                                   "writes only inside its folder: remove the link, or give another --name")
    assert [p.name for p in target.iterdir()] == ["keep.txt"]
    assert (target / "keep.txt").read_text() == "the user's\n"
    assert not (report / "README.md").exists()


def _samples(run: Path, size: int, names: tuple[str, ...]) -> None:
    """Test frame 0 of ``cbox`` saved as ``mcd.lit.samples`` saves it: ``samples/cbox/0000_<name>.exr``."""
    rng = np.random.default_rng(size)
    for name in names:
        image = rng.random((size, size, 3), dtype=np.float32)
        write_exr(run / "samples" / "cbox" / f"0000_{name}.exr", image)


@pytest.mark.slow
@pytest.mark.parametrize("differ", ["data_settings", "capacity_profile", "nothing", "transfer_scenes"])
def test_runs_of_other_data_or_capacity_under_one_profile_make_no_finding_and_no_crash(tmp_path, differ):
    sweep, unet = _sweep(tmp_path)
    base = {"data_profile": "tiny", "capacity_profile": "cpu",
            "data_settings": {"name": "test32", "width": 32, "height": 32}}
    other = {"data_settings": {"data_settings": {"name": "test48", "width": 48, "height": 48}},
             "capacity_profile": {"capacity_profile": "paper"}, "nothing": {},
             "transfer_scenes": {"data_settings": {**base["data_settings"],
                                                   "transfer_scenes": ["cornell-box-picture"]}}}[differ]
    for run, extra in ((sweep / "F_spp4", {}), (unet, other)):
        path = run / "metrics.json"
        path.write_text(json.dumps({**json.loads(path.read_text()), **base, **extra}))
    _samples(sweep / "F_spp4", 32, ("output", "reference", "noisy_4spp"))
    _samples(unet, 48 if differ == "data_settings" else 32, ("output",))
    proc = _report(tmp_path, str(sweep))
    assert proc.returncode == 0, proc.stderr  # the strips met a 48x48 output beside a 32x32 reference
    report = tmp_path / "reports" / "t"
    found = json.loads((report / "findings.json").read_text())["findings"]
    findings = (report / "README.md").read_text().split("## Findings", 1)[1].split("## Table 1", 1)[0]
    assert (report / "strips" / "cbox.png").is_file()
    if differ in ("nothing", "transfer_scenes"):  # one kind of data (transfer scenes are scored apart)
        assert found != [] and "None: the runs come from" not in findings
        return
    named = ("`tiny` (height=32, name=test32, width=32) (1 run), `tiny` (height=48, name=test48, width=48) "
             "(1 run)" if differ == "data_settings" else "`tiny` capacity `cpu` (1 run), `tiny` capacity "
             "`paper` (1 run)")
    assert found == []
    assert f"None: the runs come from 2 data profiles, capacity profiles or data settings, {named}" \
        in findings


@pytest.mark.slow
@pytest.mark.parametrize("file", ["metrics.json", "frames.csv", ".hydra/overrides.yaml"])
def test_a_record_that_is_a_fifo_fails_that_run_instead_of_waiting_for_ever(tmp_path, file):
    sweep, bad = _sweep(tmp_path)
    (sweep / "multirun.yaml").write_text("hydra:\n  overrides:\n    task: [+experiment=F,unet]\n")
    (bad / file).unlink(missing_ok=True)
    os.mkfifo(bad / file)
    proc = _report_process(tmp_path, str(sweep))  # it waited on the FIFO until the timeout: a process
    assert proc.returncode == 1, proc.stderr
    assert f"error: {bad.resolve() / file} is corrupt (not a regular file)" in proc.stderr, proc.stderr
    assert "2 found, 1 finished, 1 failed" in (tmp_path / "reports" / "t" / "README.md").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("how", ["profile", "--name"])
def test_a_current_report_without_readme_markers_is_refused_before_anything_is_written(tmp_path, how):
    sweep, unet = _sweep(tmp_path)
    if how == "profile":  # the report's name comes from the runs' data profile
        for run in (sweep / "F_spp4", unet):
            path = run / "metrics.json"
            path.write_text(json.dumps({**json.loads(path.read_text()), "data_profile": "small_current"}))
    top = tmp_path / "top"
    top.mkdir()
    (top / "README.md").write_text("# my README, without the results markers\n")
    name = ["--name", "small_current"] if how == "--name" else []
    argv = [str(sweep), "--out", str(top / "reports"), *name, "--no-viewer", "--current", "small_current"]
    proc = report_in_worker(argv, tmp_path)
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    readme = top / "README.md"
    assert proc.stderr.startswith(f"error: the report small_current is the current one, whose results go "
                                  f"into {readme}: {readme} needs exactly one line"), proc.stderr
    assert not (top / "reports").exists()
    assert (top / "README.md").read_text() == "# my README, without the results markers\n"


@pytest.mark.parametrize(("text", "why"), [
    ("method,device,height,width,ms_median\nF,cpu,abc,16,5.0\n", "a height that is not a whole number"),
    ("method,device,ms_median\nF,cpu,5.0\n", "no column height, width"),
])
@pytest.mark.slow
def test_a_damaged_bench_csv_is_named_before_anything_is_written(tmp_path, text, why):
    sweep, _ = _sweep(tmp_path)
    bench = tmp_path / "bench.csv"
    bench.write_text(text)
    proc = report_in_worker([str(sweep), "--out", str(tmp_path / "reports"), "--name", "t", "--no-viewer",
                             "--bench", str(bench)], tmp_path)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.strip() == (f"error: --bench {bench}: {why}; give a CSV of python -m mcd.bench speed "
                                   "as --bench"), proc.stderr
    assert not (tmp_path / "reports").exists()
