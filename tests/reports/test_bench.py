"""`python -m mcd.bench`: real forward passes of registered methods, CSV columns of the interface, the F/OIDN
ratio line, and the GPU paths (skipped without CUDA)."""

from __future__ import annotations

import csv

import pytest
import torch

from mcd.bench import speed as bench
from mcd.bench.__main__ import MODES
from mcd.bench.__main__ import main as bench_command
from mcd.core import allocator

INTERFACE = ["method", "device", "dtype", "compiled", "height", "width", "ms_median", "fps"]


@pytest.mark.slow
def test_bench_cpu_writes_the_interface_columns(tmp_path):
    out = tmp_path / "bench" / "bench.csv"
    bench.main(
        [
            "--methods",
            "F,A",
            "--sizes",
            "32x32",
            "--devices",
            "cpu",
            "--warmup",
            "1",
            "--reps",
            "2",
            "--out",
            str(out),
            "--synthetic",
            "--allocator",
            "system",
            "capacity=cpu",
        ]
    )
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0])[:8] == INTERFACE
    # the setting the process runs with (process-wide: a test before this one may have kept freed memory)
    assert {r["allocator"] for r in rows} == {allocator.policy()}
    assert {r["method"] for r in rows} == {"F", "A"}
    for r in rows:
        assert r["status"] == "ok", r
        assert (r["height"], r["width"]) == ("32", "32")
        ms, fps = float(r["ms_median"]), float(r["fps"])
        assert ms > 0 and fps == pytest.approx(1e3 / ms, rel=1e-3)
    # fp32 contiguous and channels-last are always measured on CPU
    assert {(r["dtype"], r["channels_last"]) for r in rows if r["method"] == "F"} >= {
        ("fp32", "False"),
        ("fp32", "True"),
    }
    readme = (out.parent / "README.md").read_text()
    assert "python -m mcd.bench" in readme and "| F | cpu | 32x32 |" in readme



@pytest.mark.slow
def test_bench_without_out_writes_under_outputs_not_reports(tmp_path, monkeypatch):
    """A measurement changes no tracked file unless asked: without ``--out`` the CSV and
    its README go to ``outputs/bench/`` under the working directory."""
    monkeypatch.chdir(tmp_path)
    bench.main(["--methods", "noisy", "--sizes", "16x16", "--devices", "cpu", "--warmup", "0", "--reps", "1",
                "--synthetic", "--allocator", "system", "capacity=cpu"])
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file()) == [
        "outputs/bench/README.md", "outputs/bench/bench.csv"]

def test_unknown_method_is_a_row_not_a_crash(tmp_path):
    rows = bench.run(["no_such_method"], ["32x32"], ["cpu"], ["capacity=cpu"], 0, 1, 1, 1, False, None)
    assert len(rows) == 1 and rows[0].ms_median is None and rows[0].status.startswith("failed to build")


def test_unknown_scene_is_named_before_any_work():
    with pytest.raises(ValueError, match="no_such_scene"):
        bench.store_frame("tiny", "no_such_scene")


@pytest.mark.slow
def test_store_frames_are_read_through_the_store_and_tiled(cbox_store):
    """The inputs are what the models see (StoreBuilder.load: exposure, sanitised), tiled to size."""
    _, store = cbox_store
    source = bench.StoreFrame(store, "cbox", 1)
    buffers, inputs = bench.frame_buffers({"c1", "depth"}, 40, 70, source)
    assert buffers["c1"].shape == (40, 70, 3) and buffers["depth"].shape == (40, 70, 1)
    assert "store test32/cbox frame 0001" in inputs
    loaded = store.load("cbox", 1, "c1")
    assert (buffers["c1"][32:40, 32:64] == loaded[:8]).all()


@pytest.mark.slow
def test_rows_carry_macs_throughput_memory_and_threads(cbox_store):
    _, store = cbox_store
    rows = bench.run(["F", "unet"], ["32x32"], ["cpu"], ["capacity=cpu"], 1, 1, 1, 1, False,
                     bench.StoreFrame(store, "cbox"))
    for r in rows:
        assert r.status == "ok", r
        assert r.threads == torch.get_num_threads() and r.gmacs > 0
        assert r.gmac_per_s == pytest.approx(r.gmacs / r.ms_median * 1e3)
        assert r.peak_rss_gb is not None and 0.05 < r.peak_rss_gb < 8
        assert r.inputs.startswith("store test32/cbox")
    lines = bench.summary(rows)
    assert any("F / U-Net achieved GMAC/s on cpu at 32x32" in line for line in lines)
    assert any("Largest peak RSS on cpu at 32x32" in line and "within the 8 GB" in line for line in lines)


def test_ratio_line_compares_f_with_oidn():
    common = dict(
        device="cuda",
        compiled=False,
        height=1080,
        width=1920,
        channels_last=True,
        reps=10,
        warmup=3,
        capacity="paper",
        inputs="synthetic (seeded)",
        status="ok",
        device_name="gpu",
        threads=1,
        gmacs=None,
    )
    rows = [
        bench.Row(method="F", dtype="fp16", ms_median=8.0, fps=125.0, **common),
        bench.Row(method="oidn", dtype="fp32", ms_median=4.0, fps=250.0, **common),
    ]
    assert any("= 2.00x" in line for line in bench.summary(rows))
    # with MACs, the ratio splits into MACs x GMAC/s, and the rate F would need is set beside the ceiling
    rows[0].gmacs, rows[0].gmac_per_s = 400.0, 50.0
    rows[1].gmacs, rows[1].gmac_per_s = 200.0, 50.0
    lines = bench.summary(rows, {"cuda fp16": 300.0, "cpu fp32": 99.0})
    split = next(line for line in lines if "= MACs" in line)
    assert "(2.00x) x GMAC/s 50.0 / 50.0 (1.00x)" in split
    assert "would need 100000.0 GMAC/s" in split  # 400 GMACs in 4 ms
    assert "dense matmul here: fp16 300.0 GMAC/s" in split and "99.0" not in split


@pytest.mark.slow
def test_matmul_ceiling_is_a_measured_rate():
    ceilings = bench.matmul_ceilings(["cpu"])
    assert set(ceilings) == {f"cpu {p.dtype_name}" for p in bench.inference_paths(torch.device("cpu"), False)}
    assert all(0.1 < rate < 1e5 for rate in ceilings.values())


def test_cpu_paths_respect_cpu_support():
    paths = bench.inference_paths(torch.device("cpu"), cpu_compile=False)
    assert not any(p.compiled for p in paths)
    assert any(p.dtype == torch.bfloat16 for p in paths) == bench.cpu_bf16_supported()


def test_cuda_paths_compile_unless_told_not_to():
    """The CUDA path list is built from the config alone (no GPU needed): the compiled half paths are there by
    default and gone with ``--no-cuda-compile``, the eager ones stay."""
    cuda = torch.device("cuda")
    default = bench.inference_paths(cuda, False)
    eager = bench.inference_paths(cuda, False, cuda_compile=False)
    assert [p for p in default if not p.compiled] == eager
    assert not any(p.compiled for p in eager)
    halves = {p.dtype for p in eager if p.dtype is not None}
    assert {p.dtype for p in default if p.compiled} == halves != set()


@pytest.mark.skipif(
    not torch.cuda.is_available(), reason="needs a CUDA GPU (fp16/bf16, channels-last, compile)"
)
def test_bench_gpu_paths(tmp_path):
    out = tmp_path / "bench.csv"
    bench.main(
        [
            "--methods",
            "F,oidn",
            "--sizes",
            "64x64",
            "--devices",
            "cuda",
            "--warmup",
            "2",
            "--reps",
            "3",
            "--out",
            str(out),
            "capacity=cpu",
        ]
    )
    rows = [r for r in csv.DictReader(out.open()) if r["method"] == "F"]
    assert {r["dtype"] for r in rows} >= {"fp32", "fp16"}
    assert any(r["compiled"] == "True" for r in rows)
    assert all(r["status"] == "ok" for r in rows), rows


@pytest.mark.slow
def test_profile_prints_every_stage_of_row_f(tmp_path, capsys):
    """`python -m mcd.bench profile`: a real profiled forward of row
    F; each stage label has a time in the exclusive table, whose rows add up to its frame, and the labels
    with modules have their MACs in the inclusive one."""
    out = tmp_path / "profile.md"
    bench_command(["profile", "--size", "48x32", "--dtype", "fp32", "--synthetic", "--out", str(out),
                "capacity=cpu"])
    text = capsys.readouterr().out
    assert text.strip() == out.read_text().strip()
    exclusive, inclusive = text.split("| label, nested labels included |")
    cells = [[c.strip() for c in line.split("|")[1:-1]] for line in exclusive.splitlines()
             if line.startswith("| ") and not line.startswith("| stage")]
    rows = {c[0].replace("&nbsp;", ""): c[1:] for c in cells}
    for stage in ("input packing", "F_s", "Ghost conv", "adaptive render", "map normalisation", "kernel pool",
                  "kernel-map head", "kernel application", "F_d", "L0", "PP", "SA", "output steps", "other",
                  "**sum of stages**", "**frame**"):
        assert stage in rows, stage
    printed = [float(c[1]) for c in cells if not c[0].startswith("**")]
    stages = sum(printed)
    # each row is printed to 0.01 ms, so the printed rows may miss the printed sum by half a unit per row
    assert stages == pytest.approx(float(rows["**sum of stages**"][0]), abs=0.005 * (len(printed) + 1))
    assert stages == pytest.approx(float(rows["**frame**"][0]), rel=0.1)
    lines = [line for line in inclusive.splitlines() if line.startswith("| ")]
    nested = {c[0]: c[1:] for c in ([x.strip() for x in line.split("|")[1:-1]] for line in lines)}
    for label in ("F_s", "kernel-map head", "F_d", "PP", "SA"):
        ms, gmacs, rate = nested[label]
        assert float(ms) > 0 and float(gmacs) > 0 and float(rate) > 0, label


def _help(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit) as done:
        bench_command(argv)
    assert done.value.code == 0
    return capsys.readouterr().out


def test_help_lists_every_mode_and_each_mode_has_its_own_help(capsys):
    """`python -m mcd.bench --help` names every mode and its tool; `MODE --help` is that tool's own parser."""
    top = _help(["--help"], capsys)
    for mode, (module, _) in MODES.items():
        assert mode in top and module in top, mode
        own = _help([mode, "--help"], capsys)
        prog = f"python -m mcd.bench {'[speed]' if mode == 'speed' else mode}"
        assert own.startswith(f"usage: {prog}"), own[:80]


def test_a_word_that_names_no_mode_is_refused_before_any_work(capsys):
    """`python -m mcd.bench startup` (a mode no more: the lab's tools/startup_bench.py) or a typo ends with
    exit status 2 and the modes listed, instead of running the speed mode; an override first means speed."""
    with pytest.raises(SystemExit) as done:
        bench_command(["startup", "--runs", "1"])
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'startup'" in err and all(f"'{mode}'" in err for mode in MODES)
    assert _help(["capacity=cpu", "--help"], capsys).startswith("usage: python -m mcd.bench [speed]")
