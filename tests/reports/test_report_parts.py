"""Parts of `mcd.report`: reading run dirs of every status, the paper's claims stated against the numbers,
crop placement, markdown cells."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from mcd.report import make_report
from mcd.reporting.runs import find_runs
from mcd.reporting.select import pick, to_markdown
from mcd.reporting.strips import crop_box
from mcd.reporting.tables import component_checks


def _job(root, name, metrics=None, error=None, metrics_text=None, experiment="F", budget=4, sweep="ablation"):
    d = root / name
    (d / ".hydra").mkdir(parents=True)
    (d / ".hydra" / "config.yaml").write_text(
        f"experiment: {experiment}\nbudget: {budget}\nsweep_name: {sweep}\n"
    )
    (d / ".hydra" / "overrides.yaml").write_text(f"- +experiment={experiment}\n")
    if metrics is not None:
        (d / "metrics.json").write_text(json.dumps(metrics))
    if metrics_text is not None:
        (d / "metrics.json").write_text(metrics_text)
    if error is not None:
        (d / "error.json").write_text(json.dumps(error))
    return d


def test_runs_of_every_status_are_found(tmp_path):
    _job(tmp_path, "ok", metrics={"psnr": 30.0, "experiment": "F", "budget": 4})
    _job(tmp_path, "failed", error={"error": "ValueError: KP needs AS\nmore"}, experiment="C")
    _job(tmp_path, "killed", experiment="A")
    _job(tmp_path, "truncated", metrics_text='{"psnr": 3', experiment="B")
    runs = {r.path.name: r for r in find_runs([tmp_path])}
    assert {k: r.status for k, r in runs.items()} == {
        "ok": "ok",
        "failed": "failed",
        "killed": "incomplete",
        "truncated": "failed",  # a corrupt record (mcd.run writes it atomically): named, not "killed"
    }
    assert runs["truncated"].error_message.startswith(f"{runs['truncated'].path / 'metrics.json'} is corrupt")
    assert runs["failed"].error_message == "ValueError: KP needs AS"
    assert runs["failed"].overrides == ["+experiment=C"]
    assert "killed" in runs["killed"].error_message
    assert runs["ok"].sweep == "ablation" and runs["ok"].budget == 4.0


def test_pick_prefers_finished_runs_of_the_preferred_sweep(tmp_path):
    _job(tmp_path / "spp", "a", metrics={"psnr": 1.0, "experiment": "F", "budget": 4})
    _job(tmp_path / "abl", "b", metrics={"psnr": 2.0, "experiment": "F", "budget": 4})
    _job(tmp_path / "abl", "c", error={"error": "x"})
    runs = find_runs([tmp_path])
    for r in runs:
        r.config["sweep_name"] = r.path.parent.name
    assert pick(runs, "F", 4.0, prefer_sweep="abl").metrics["psnr"] == 2.0
    assert pick(runs, "F", 4.0, prefer_sweep="spp").metrics["psnr"] == 1.0
    assert pick(runs, "F", 8.0, prefer_sweep="abl") is None


def test_spp_rows_fill_the_unet_gaps_with_row_a(tmp_path):
    from mcd.reporting.spp import spp_frame

    _job(tmp_path, "u8", metrics={"psnr": 20.0, "experiment": "unet", "budget": 8}, experiment="unet",
         budget=8, sweep="spp")
    _job(tmp_path, "a4", metrics={"psnr": 18.0, "experiment": "A", "budget": 4}, experiment="A")
    df = spp_frame(find_runs([tmp_path])).set_index(["experiment", "budget"])
    assert df.loc[("unet", 4.0), "psnr"] == 18.0 and df.loc[("unet", 4.0), "source"] == "A"
    assert df.loc[("unet", 8.0), "psnr"] == 20.0 and df.loc[("unet", 8.0), "source"] == "unet"


def _comp(psnr):
    return pd.DataFrame(
        {
            "row": list(psnr),
            "PSNR": list(psnr.values()),
            "PSNR paper": [33.0 + 0.1 * i for i in range(len(psnr))],
        }
    )


def test_claims_hold_when_they_hold():
    lines = component_checks(_comp({"A": 30.0, "B": 30.2, "C": 31.5, "D": 31.6, "E": 31.7, "F": 31.8}))
    ours = lines[0]
    assert ours.startswith("ours: F above A holds") and "largest single step: holds" in ours
    assert "B→C +1.30 dB" in ours


def test_claims_are_reported_plainly_when_our_data_disagree():
    ours = component_checks(_comp({"A": 30.0, "B": 30.9, "C": 30.5, "D": 30.6, "E": 30.0, "F": 29.5}))[0]
    assert "F above A does NOT hold" in ours and "(F 29.50 dB vs A 30.00 dB, -0.50 dB)" in ours
    assert "does NOT hold (largest step is A→B)" in ours


def test_claims_with_missing_rows_say_which():
    ours = component_checks(_comp({"A": 30.0, "B": math.nan, "C": 31.0, "D": 31.0, "E": 31.0, "F": 31.0}))[0]
    assert "rows B have no PSNR" in ours


def test_crop_lands_on_the_noisiest_window():
    ref = np.full((40, 60, 3), 0.5, np.float32)
    noisy = ref.copy()
    noisy[20:30, 41:51] = np.random.default_rng(0).gamma(0.3, 10.0, size=(10, 10, 3))
    assert crop_box(noisy, ref, 10) == (20, 41)
    assert crop_box(noisy, ref, 100) == (0, 0)


def test_markdown_marks_missing_values():
    md = to_markdown(pd.DataFrame({"m": ["x"], "v": [math.nan], "w": [1.234]}))
    assert md.splitlines()[2] == "| x | — | 1.23 |"


def _seed_job(root, exp, seed, psnr):
    metrics = {"psnr": psnr, "ssim": 0.5 + psnr / 100, "experiment": exp, "budget": 4, "seed": seed}
    return _job(root, f"{exp}_spp4_seed{seed}", metrics=metrics, experiment=exp, sweep="seeds")


def test_seeds_table_gives_spread_and_differences_with_standard_errors(tmp_path):
    from mcd.reporting import seeds

    psnrs = [(20.0, 20.5, 21.5, 22.0), (21.0, 20.5, 22.5, 21.0), (20.0, 21.5, 21.5, 23.0)]
    for s, (a, b, c, f) in enumerate(psnrs):
        for exp, v in zip("ABCF", (a, b, c, f), strict=True):
            _seed_job(tmp_path, exp, s, v)
    _job(tmp_path, "A_spp4_failed", error={"error": "x"}, experiment="A", sweep="seeds")  # not counted
    # a job of another sweep
    _job(tmp_path, "F_abl", metrics={"psnr": 99.0, "experiment": "F", "budget": 4}, sweep="ablation")
    out = seeds.write(find_runs([tmp_path]), tmp_path)
    table = out["seeds"].set_index("row")
    assert list(table.index) == ["A", "B", "C", "F"] and (table["n"] == 3).all()
    assert table.loc["A", "PSNR mean"] == 61 / 3 and table.loc["F", "PSNR max"] == 23.0
    assert math.isclose(table.loc["F", "PSNR std"], 1.0)  # 22, 21, 23
    diffs = out["seeds_differences"].set_index("difference")
    assert list(diffs.index) == ["B - A", "C - B", "F - C", "F - A"]
    assert diffs.loc["F - C", "adds"] == "PP+FG+SA" and diffs.loc["F - A", "adds"] == "AS+KP+PP+FG+SA"
    fa = diffs.loc["F - A"]
    assert math.isclose(fa["mean dB"], 22.0 - 61 / 3)
    assert math.isclose(fa["se dB"], math.sqrt(1.0 / 3 + (1 / 3) / 3))  # s_F^2 = 1, s_A^2 = 1/3
    assert fa["ranges"] == "overlap"
    lines = seeds.checks(out["seeds_differences"])
    assert lines[0].startswith("4 spp: F - A = +1.67 ± 0.67 dB")
    assert "2.5 standard errors from zero: resolved" in lines[0] and "F above A holds" in lines[0]
    # F - C spans three components: listed, not ranked against the single steps B - A and C - B
    assert "C - B (KP) = +1.00 ± 0.47 dB, 2.1 standard errors from zero: resolved" in lines[1]
    assert "it is the largest of the 2 single-component steps" in lines[1] and "F - C (PP+FG+SA)" in lines[1]
    md = (tmp_path / "seeds.md").read_text()
    assert "Differences of mean PSNR" in md and (tmp_path / "seeds_differences.csv").is_file()


def test_seeds_give_the_differences_over_the_training_scenes_too(tmp_path):
    """The all-scene mean includes the held-out scene; the paper's protocol is the training scenes' test
    frames. Here C - B is the largest step over all scenes only because of the held-out scene."""
    from mcd.reporting import seeds

    # (cbox, room0: training scenes; veach-ajar: held out) per row and seed
    scores = {"A": [(20.0, 20.0, 10.0), (20.2, 20.2, 10.0)], "B": [(22.0, 22.0, 10.0), (22.4, 22.4, 10.0)],
              "C": [(22.5, 22.5, 16.0), (22.7, 22.7, 16.0)]}
    for exp, per_seed in scores.items():
        for seed, (cbox, room0, veach) in enumerate(per_seed):
            d = _seed_job(tmp_path, exp, seed, (cbox + room0 + veach) / 3)
            metrics = json.loads((d / "metrics.json").read_text())
            metrics["per_scene"] = {"cbox": {"psnr": cbox}, "room0": {"psnr": room0},
                                    "veach-ajar": {"psnr": veach}}
            (d / "metrics.json").write_text(json.dumps(metrics))
            (d / ".hydra" / "config.yaml").write_text(
                f"experiment: {exp}\nbudget: 4\nsweep_name: seeds\nseed: {seed}\n"
                "data:\n  train_scenes: [cbox, room0]\n")
    out = seeds.write(find_runs([tmp_path]), tmp_path)
    table = out["seeds"].set_index("row")
    assert table.loc["C", "PSNR train scenes mean"] == pytest.approx(22.6)
    assert table.loc["B", "PSNR train scenes std"] == pytest.approx(math.sqrt(0.08))
    diffs = out["seeds_differences"].set_index("difference")
    assert diffs.loc["C - B", "train mean dB"] == pytest.approx(0.4)
    assert diffs.loc["B - A", "train mean dB"] == pytest.approx(2.1)
    [line] = seeds.checks(out["seeds_differences"])
    assert "it is the largest of the 2 single-component steps" in line
    assert "On the training scenes' test frames (the paper's protocol): +0.40 ± 0.22 dB." in line
    assert line.endswith("It is NOT the largest step there (largest: B - A).")


def test_repeatability_compares_a_seed_with_the_same_job_of_another_sweep(tmp_path):
    from mcd.reporting import seeds

    _seed_job(tmp_path, "F", 0, 21.25)
    _seed_job(tmp_path, "F", 1, 22.0)
    _job(tmp_path, "F_abl", metrics={"psnr": 21.0, "experiment": "F", "budget": 4}, sweep="ablation")
    _job(tmp_path, "A_abl", metrics={"psnr": 5.0, "experiment": "A", "budget": 4}, sweep="ablation")
    (line,) = seeds.reproducibility(find_runs([tmp_path]))
    assert "1 seeds-sweep job(s) (F)" in line and line.endswith("largest PSNR difference 0.2500 dB.")


def test_seeds_absent_writes_nothing(tmp_path):
    from mcd.reporting import seeds

    _job(tmp_path, "F", metrics={"psnr": 30.0, "experiment": "F", "budget": 4})
    assert seeds.write(find_runs([tmp_path]), tmp_path) == {}
    assert not (tmp_path / "seeds.md").exists() and seeds.checks(pd.DataFrame()) == []


def test_pick_takes_the_default_seed_over_other_seeds(tmp_path):
    _seed_job(tmp_path, "F", 1, 25.0)
    _seed_job(tmp_path, "F", 0, 24.0)
    assert pick(find_runs([tmp_path]), "F", 4.0, prefer_sweep="ablation").metrics["psnr"] == 24.0


def test_a_difference_under_two_standard_errors_is_called_unresolved():
    from mcd.reporting.seeds import _resolved

    assert _resolved(0.33, 0.24) == "1.4 standard errors from zero: NOT resolved by these seeds"
    assert _resolved(-0.6, 0.2).startswith("3.0 standard errors from zero: resolved")
    assert _resolved(0.5, math.nan) == "spread unknown"


def test_seeds_run_without_ssim_shows_a_gap_not_a_crash(tmp_path):
    from mcd.reporting import seeds

    _job(tmp_path, "F_spp4_seed0", metrics={"psnr": 21.0, "experiment": "F", "budget": 4, "seed": 0},
         sweep="seeds")
    _seed_job(tmp_path, "F", 1, 22.0)
    row = seeds.spread(find_runs([tmp_path])).iloc[0]
    assert row["n"] == 2 and row["PSNR mean"] == 21.5 and math.isnan(row["SSIM mean"])


def test_the_ablation_sweeps_seed_0_completes_a_seeds_sweep_run_from_seed_1(tmp_path):
    """`+sweep=seeds seed=1,2,3,4` reuses the ablation job of seed 0 (the same job); a seeds-sweep seed 0,
    where there is one, wins; other experiments' ablation jobs stay out."""
    from mcd.reporting import seeds

    for s, v in ((1, 22.0), (2, 23.0)):
        _seed_job(tmp_path, "F", s, v)
    metrics = {"psnr": 21.0, "ssim": 0.7, "experiment": "F", "budget": 4, "seed": 0}
    _job(tmp_path / "abl", "F_spp4", metrics=metrics, sweep="ablation")
    _job(tmp_path / "abl", "A_spp4", metrics={**metrics, "experiment": "A"}, experiment="A", sweep="ablation")
    (tmp_path / "out1").mkdir()
    (tmp_path / "out2").mkdir()
    table = seeds.write(find_runs([tmp_path]), tmp_path / "out1")["seeds"].set_index("row")
    assert list(table.index) == ["F"] and table.loc["F", "n"] == 3 and table.loc["F", "PSNR mean"] == 22.0
    assert seeds.reproducibility(find_runs([tmp_path])) == []  # the stand-in is not compared with itself
    _seed_job(tmp_path, "F", 0, 24.0)
    table = seeds.write(find_runs([tmp_path]), tmp_path / "out2")["seeds"].set_index("row")
    assert table.loc["F", "n"] == 3 and table.loc["F", "PSNR mean"] == 23.0


def test_transfer_table_sets_oidn_on_the_held_out_scene_beside_the_transfer_jobs(tmp_path):
    from mcd.reporting.tables import transfer

    scores = {"psnr": 26.5, "ssim": 0.8, "rmse": 0.1, "input_psnr": 7.3, "flip": 0.2}
    _job(tmp_path, "oidn", experiment="oidn", sweep="baselines",
         metrics={"psnr": 30.0, "experiment": "oidn", "budget": 4,
                  "per_scene": {"cbox": {"psnr": 34.0}, "veach-ajar": scores}})
    for ft in (0, 30):
        _job(tmp_path, f"F_ft{ft}", sweep="transfer",
             metrics={"psnr": 20.0 + ft / 10, "experiment": "F", "budget": 4,
                      "transfer": {"scene": "veach-ajar", "finetune": ft > 0, "finetune_epochs": ft}})
    table = transfer(find_runs([tmp_path])).set_index("method")
    assert list(table.index) == ["Ours (F)", "Ours (F)", "OIDN"]
    oidn = table.loc["OIDN"]
    assert oidn["scene"] == "veach-ajar" and oidn["PSNR"] == 26.5 and oidn["SSIM"] == 80.0
    assert oidn["input PSNR"] == 7.3 and oidn["FLIP"] == 20.0 and math.isnan(oidn["L_t"])
    assert "no training" in oidn["run"]


def test_findings_state_fs_standing_against_baselines_oidn_and_its_input(tmp_path):
    from mcd.reporting import findings
    from mcd.reporting.spp import spp_frame
    from mcd.reporting.tables import table1

    per = {"cbox": {"psnr": 28.0}, "room0": {"psnr": 27.0}, "veach-ajar": {"psnr": 20.0}}
    for budget, psnr, noisy in ((4, 25.0, 17.0), (32, 26.0, 27.0)):
        d = _job(tmp_path, f"F{budget}", experiment="F", budget=budget,
                 metrics={"psnr": psnr, "experiment": "F", "budget": budget, "per_scene": per})
        (d / ".hydra" / "config.yaml").write_text(
            f"experiment: F\nbudget: {budget}\nsweep_name: ablation\ndata:\n  train_scenes: [cbox, room0]\n")
        _job(tmp_path, f"noisy{budget}", experiment="noisy", budget=budget, sweep="baselines",
             metrics={"psnr": noisy, "experiment": "noisy", "budget": budget})
    oidn_scenes = {"cbox": {"psnr": 34.0}, "room0": {"psnr": 29.0}, "veach-ajar": {"psnr": 27.0}}
    _job(tmp_path, "oidn", experiment="oidn", sweep="baselines",
         metrics={"psnr": 30.0, "experiment": "oidn", "budget": 4, "per_scene": oidn_scenes})
    _job(tmp_path, "rae", experiment="rae", sweep="baselines",
         metrics={"psnr": 25.5, "experiment": "rae", "budget": 4})
    _job(tmp_path, "A", experiment="A", metrics={"psnr": 24.0, "experiment": "A", "budget": 4})
    runs = find_runs([tmp_path])
    [line] = findings.baselines(table1(runs))
    assert "does NOT hold: RAE 25.50 dB (+0.50)" in line and "FastDVDnet, DASR, NTASAD not finished" in line
    t1 = table1(runs)
    # Table 1 beside its all-scene mean: the training scenes' test frames (the paper's protocol), NaN for a
    # run whose per-scene scores do not cover them
    psnr_train = t1.set_index("experiment")["PSNR train scenes"]
    assert psnr_train["F"] == pytest.approx(27.5) and math.isnan(psnr_train["rae"])
    [line] = findings.baselines(t1[t1["experiment"] != "rae"])  # only the U-Net (row A), below F
    assert "holds against those finished so far; F 25.00 dB, +1.00 dB" in line
    assert "(FastDVDnet, RAE, DASR, NTASAD not finished)" in line
    gap = findings.oidn_gap(runs)
    assert gap[0].startswith("F - OIDN at 4 spp over all test scenes: -5.00 dB")
    assert "training scenes' test frames: -4.00 dB (F 27.50, OIDN 31.50)" in gap[1] and "is NOT met" in gap[1]
    assert "veach-ajar -7.00" in gap[1]
    spread = pd.DataFrame([{"row": "F", "spp": 4, "n": 4, "PSNR train scenes mean": 30.75,
                            "PSNR train scenes std": 0.3}])
    assert findings.oidn_gap(runs, spread=spread)[2] == (
        "Over 4 seeds of F: -0.75 dB on the training scenes' test frames (F's mean 30.75, standard deviation "
        "0.30 dB); the aim is met by the mean.")
    [line] = findings.above_input(spp_frame(runs))
    assert "does NOT hold at 32 spp (-1.00 dB) (not measured yet: 2, 8, 16 spp)" in line
    assert "4 spp +8.00" in line
    # only the budgets that ran: a verdict that does not claim the others
    only4 = spp_frame(runs)
    [line] = findings.above_input(only4[only4["budget"] == 4])
    assert "holds at every budget measured so far (not measured yet: 2, 8, 16, 32 spp)" in line
    # per budget, the best other trained method (here RAE at 4 spp only) and OIDN where they ran
    assert findings.against_budgets(spp_frame(runs)) == [
        "F - the best other trained method per budget (one seed each): 4 spp -0.50 (RAE) dB.",
        "F - OIDN per budget: 4 spp -5.00 dB."]


def test_a_baseline_trained_with_the_papers_loss_is_a_row_after_its_own_only_where_it_ran(tmp_path):
    from mcd.reporting import findings
    from mcd.reporting.tables import table1

    for exp, psnr in (("F", 25.0), ("dasr", 22.0)):
        _job(tmp_path, exp, experiment=exp, sweep="baselines",
             metrics={"psnr": psnr, "experiment": exp, "budget": 4})
    rows = list(table1(find_runs([tmp_path]))["experiment"])
    assert "dasr_paper_loss" not in rows
    _job(tmp_path, "dasr_paper_loss", experiment="dasr_paper_loss", sweep="baselines",
         metrics={"psnr": 26.0, "experiment": "dasr_paper_loss", "budget": 4})
    t1 = table1(find_runs([tmp_path])).set_index("experiment")
    assert list(t1.index).index("dasr_paper_loss") == list(t1.index).index("dasr") + 1
    assert t1.loc["dasr_paper_loss", "method"] == "DASR (paper's loss)"
    assert t1.loc["dasr_paper_loss", "PSNR paper"] == t1.loc["dasr", "PSNR paper"]
    [line] = findings.baselines(t1.reset_index())
    assert "does NOT hold: DASR (paper's loss) 26.00 dB (+1.00)" in line and "seeds" not in line
    spread = pd.DataFrame([{"row": "F", "spp": 4, "n": 3, "PSNR mean": 25.1, "PSNR std": 0.4,
                            "PSNR min": 24.6, "PSNR max": 25.4}])
    [line] = findings.baselines(t1.reset_index(), spread)
    assert line.endswith("Over 3 seeds F's PSNR has a mean of 25.10 dB (-0.90 against the best baseline) "
                         "and a standard deviation of 0.40 dB (range 24.60-25.40); the best baseline's "
                         "26.00 dB lies above F's whole range; each baseline ran one seed.")
    spread["PSNR max"] = 26.2
    [line] = findings.baselines(t1.reset_index(), spread)
    assert "the best baseline's 26.00 dB lies within F's range" in line


def test_a_sweep_split_over_two_processes_reports_one_command_that_runs_every_job(tmp_path):
    from mcd.reporting.runs import find_sweeps

    sweep = tmp_path / "seeds" / "small"
    for exp, seed in (("A", 1), ("A", 2), ("C", 1), ("C", 2)):
        d = _job(sweep, f"{exp}_s{seed}", experiment=exp)
        (d / ".hydra" / "overrides.yaml").write_text(
            f"- +sweep=seeds\n- +experiment={exp}\n- seed={seed}\n- data.test_scenes=[cbox,room0]\n")
    # the last of the two processes wrote multirun.yaml: its own experiments only
    (sweep / "multirun.yaml").write_text(
        "hydra:\n  overrides:\n    task: ['+sweep=seeds', '+experiment=C', 'seed=1,2', "
        "'data.test_scenes=[cbox,room0]', 'transfer.init_from=runs/${experiment}']\nexperiment: C\n")
    [found] = find_sweeps([tmp_path])
    assert found.command == ("python -m mcd.run -m +sweep=seeds +experiment=C,A seed=1,2 "
                             "data.test_scenes=[cbox,room0] transfer.init_from=runs/${experiment}")


def test_a_corrupt_multirun_yaml_leaves_out_its_command_not_its_runs(tmp_path, caplog):
    from mcd.reporting.runs import find_sweeps

    sweep = tmp_path / "transfer" / "small"
    _job(sweep, "F_ft0", metrics={"psnr": 20.0, "experiment": "F", "budget": 4})
    (sweep / "multirun.yaml").write_text("hydra:\n  overrides:\n    task: []\nsweep_name: transfer\nsfer\n")
    assert find_sweeps([tmp_path]) == []
    assert "unreadable" in caplog.text and "multirun.yaml" in caplog.text
    assert [r.status for r in find_runs([tmp_path])] == ["ok"]


def test_a_resumed_run_from_before_the_segment_records_is_found_by_its_curve_clock(tmp_path):
    """Runs without metrics.json ``segments``: curve.csv's clock goes on across processes, so a clock beyond
    the last process's ``train_s`` (by more than the slack) means earlier processes trained too."""
    from mcd.reporting.provenance import Provenance
    from mcd.reporting.runs import RESUMED_SLACK_S

    base = {"psnr": 30.0, "experiment": "F", "budget": 4, "commit": "c" * 40, "train_steps": 3000}
    one_go = _job(tmp_path, "one_go", metrics={**base, "train_s": 500.0, "wall_s": 510.0})
    resumed = _job(tmp_path, "resumed", metrics={**base, "train_s": 400.0, "wall_s": 410.0})
    for d, clock in ((one_go, 499.5), (resumed, 400.0 + RESUMED_SLACK_S + 1500.0)):
        (d / "curve.csv").write_text(f"step,seconds,val_psnr\n1500,{clock / 2},28.0\n3000,{clock},29.0\n")
    runs = {r.path.name: r for r in find_runs([tmp_path])}
    assert runs["one_go"].segments == []
    earlier, last = runs["resumed"].segments
    assert earlier["commit"] is None and earlier["seconds"] == pytest.approx(1530.0)
    assert last["commit"] == "c" * 40 and last["seconds"] == 400.0
    prov = Provenance.gather([], list(runs.values()), command="test")
    assert prov.resumed == "`resumed` (code not recorded, 26 min; at ccccccc, 7 min)"
    assert prov.wall_s == pytest.approx(510.0 + 410.0 + 1530.0)


def test_runs_that_would_share_a_record_folder_are_refused_before_anything_is_written(tmp_path):
    for machine in ("first", "second"):
        _job(tmp_path / machine / "ablation" / "small", "F_spp4", metrics={"psnr": 30.0, "experiment": "F",
                                                                           "budget": 4})
    with pytest.raises(ValueError, match="ablation/small/F_spp4"):
        make_report([tmp_path / "first", tmp_path / "second"], tmp_path / "reports", name="both", bench=None)
    assert not (tmp_path / "reports").exists()
