"""Parts of `mcd.report`: reading run dirs of every status, the paper's claims checked against the numbers
(as finding records, mcd/reporting/finding.py), crop placement, markdown cells."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from mcd.report import make_report
from mcd.reporting.finding import Finding, render
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


def test_the_viewer_shows_a_rows_variants_after_it_and_the_strips_do_not(tmp_path):
    """``table1_runs(variants=True)`` (the viewer's methods) puts each variant that ran right after its
    Table 1 row, as Table 1 does (F_paper after F); without it (the strips) only Table 1's rows; a variant
    that did not run is absent."""
    from mcd.reporting.strips import table1_runs

    jobs = (("A", "ablation"), ("F", "ablation"), ("ntasad", "baselines"), ("F_paper", "baselines"),
            ("oidn", "baselines"))
    for exp, sweep in jobs:
        _job(tmp_path / sweep, f"{exp}_spp4", metrics={"psnr": 20.0, "experiment": exp, "budget": 4},
             experiment=exp, sweep=sweep)
    runs = find_runs([tmp_path])
    assert [e for e, _, _ in table1_runs(runs)] == ["A", "ntasad", "F", "oidn"]
    shown = table1_runs(runs, variants=True)
    assert [e for e, _, _ in shown] == ["A", "ntasad", "F", "F_paper", "oidn"]
    assert dict((e, t) for e, t, _ in shown)["F_paper"] == "Ours (F, paper's text)"


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


def _by_kind(found, source="ours"):
    return {f.kind: f for f in found if f.source == source}


def test_claims_hold_when_they_hold():
    ours = _by_kind(component_checks(_comp(dict(A=30.0, B=30.2, C=31.5, D=31.6, E=31.7, F=31.8))))
    assert ours["f_above_a"].verdict == "holds" and ours["kp_largest_step"].verdict == "holds"
    assert ours["kp_largest_step"].detail["steps"]["B→C"] == pytest.approx(1.3)
    assert "B→C +1.30 dB" in render(ours["kp_largest_step"])


def test_claims_are_reported_plainly_when_our_data_disagree():
    ours = _by_kind(component_checks(_comp(dict(A=30.0, B=30.9, C=30.5, D=30.6, E=30.0, F=29.5))))
    assert ours["f_above_a"].verdict == "does not hold"
    assert ours["f_above_a"].values == {"F": 29.5, "A": 30.0}
    assert ours["kp_largest_step"].verdict == "does not hold"
    # a reader sees the negative verdict, and which step was the largest
    assert "does NOT hold" in render(ours["f_above_a"])
    assert "does NOT hold (largest step is A→B)" in render(ours["kp_largest_step"])


def test_claims_with_missing_rows_say_which():
    found = component_checks(_comp({"A": 30.0, "B": math.nan, "C": 31.0, "D": 31.0, "E": 31.0, "F": 31.0}))
    ours = _by_kind(found)
    assert set(ours) == {"component_rows_missing"}
    assert ours["component_rows_missing"].detail["missing"] == ["B"]
    assert _by_kind(found, "paper")["f_above_a"].verdict == "holds"


def test_a_finding_never_compares_a_method_with_itself():
    """A finding read "0.121 (F) to 0.121 (F)". A range over one row names it once; the record
    refuses a method named twice."""
    comp = _comp({r: 30.0 + i for i, r in enumerate("ABCDEF")})
    comp["KP identity"] = [math.nan, math.nan, math.nan, math.nan, math.nan, 0.121]
    comp["KP index std"] = [math.nan, math.nan, 0.2, 0.2, math.nan, 0.2]  # a tie: one row, not "C to C"
    found = _by_kind(component_checks(comp))
    for kind in ("kp_identity_share", "kp_index_spread"):
        f = found[kind]
        assert len(f.subjects) == 1, f
        assert render(f).count(f"({f.subjects[0]}") == 1
    comp["KP identity"] = [math.nan, math.nan, 0.5, 0.6, math.nan, 0.121]
    share = _by_kind(component_checks(comp))["kp_identity_share"]
    assert share.subjects == ("F", "D") and share.values == {"F": 0.121, "D": 0.6}
    with pytest.raises(ValueError, match="never compares a method with itself"):
        Finding("kp_identity_share", "measured", "KP identity", "", ("F", "F"), {"F": 0.121})


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
    f_a, kp = seeds.checks(out["seeds_differences"])
    assert f_a.kind == "seeds_f_above_a" and f_a.verdict == "holds" and f_a.budget == 4.0
    assert f_a.values["mean"] == pytest.approx(22.0 - 61 / 3)
    assert f_a.values["se"] == pytest.approx(fa["se dB"])
    assert "2.5 standard errors from zero: resolved" in render(f_a)
    # F - C spans three components: listed, not ranked against the single steps B - A and C - B
    assert kp.verdict == "holds" and kp.detail["single_steps"] == 2 and kp.detail["largest"] == "C - B"
    assert [s["difference"] for s in kp.detail["steps"]] == ["B - A", "C - B", "F - C"]
    assert kp.values["mean"] == pytest.approx(1.0) and "2.1 standard errors from zero: resolved" in render(kp)
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
    [kp] = seeds.checks(out["seeds_differences"])
    assert kp.verdict == "holds" and kp.detail["largest_train"] == "B - A"
    assert kp.values["train mean"] == pytest.approx(0.4)
    assert "NOT the largest step there (largest: B - A)" in render(kp)


def test_repeatability_compares_a_seed_with_the_same_job_of_another_sweep(tmp_path):
    from mcd.reporting import seeds

    _seed_job(tmp_path, "F", 0, 21.25)
    _seed_job(tmp_path, "F", 1, 22.0)
    _job(tmp_path, "F_abl", metrics={"psnr": 21.0, "experiment": "F", "budget": 4}, sweep="ablation")
    _job(tmp_path, "A_abl", metrics={"psnr": 5.0, "experiment": "A", "budget": 4}, sweep="ablation")
    (rep,) = seeds.reproducibility(find_runs([tmp_path]))
    assert rep.subjects == ("F",) and rep.values == {"jobs": 1.0, "largest difference": 0.25}


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
    from mcd.reporting.finding import resolved as _resolved

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
    [base] = findings.baselines(table1(runs))
    assert base.verdict == "does not hold" and base.subjects == ("F", "A", "rae")
    assert base.values == {"F": 25.0, "A": 24.0, "rae": 25.5}
    assert base.detail["missing"] == ["FastDVDnet", "DASR", "NTASAD"]
    assert "does NOT hold: RAE 25.50 dB (+0.50)" in render(base)
    t1 = table1(runs)
    # Table 1 beside its all-scene mean: the training scenes' test frames (the paper's protocol), NaN for a
    # run whose per-scene scores do not cover them
    psnr_train = t1.set_index("experiment")["PSNR train scenes"]
    assert psnr_train["F"] == pytest.approx(27.5) and math.isnan(psnr_train["rae"])
    [base] = findings.baselines(t1[t1["experiment"] != "rae"])  # only the U-Net (row A), below F
    assert base.verdict == "holds so far"
    assert base.detail["missing"] == ["FastDVDnet", "RAE", "DASR", "NTASAD"]
    assert "holds against those finished so far" in render(base)
    every, train = findings.oidn_gap(runs)
    assert every.subjects == ("F", "oidn") and every.values == {"F": 25.0, "oidn": 30.0} and every.budget == 4
    assert train.scenes == ("cbox", "room0") and train.values == {"F": 27.5, "oidn": 31.5}
    assert train.verdict == "not met" and train.detail["per_scene"]["veach-ajar"] == -7.0
    assert "is NOT met" in render(train)
    spread = pd.DataFrame([{"row": "F", "spp": 4, "n": 4, "PSNR train scenes mean": 30.75,
                            "PSNR train scenes std": 0.3}])
    seeded = findings.oidn_gap(runs, spread=spread)[2]
    assert seeded.verdict == "met" and seeded.values == {"F": 30.75, "oidn": 31.5} and seeded.detail["n"] == 4
    [above] = findings.above_input(spp_frame(runs))
    assert above.verdict == "does not hold" and above.detail["gains"] == {"4": 8.0, "32": -1.0}
    assert above.detail["not_measured"] == [2.0, 8.0, 16.0]
    assert "does NOT hold at 32 spp (-1.00 dB)" in render(above)
    # only the budgets that ran: a verdict that does not claim the others
    only4 = spp_frame(runs)
    [above] = findings.above_input(only4[only4["budget"] == 4])
    assert above.verdict == "holds so far" and above.detail["not_measured"] == [2.0, 8.0, 16.0, 32.0]
    # per budget, the best other trained method (here RAE at 4 spp only) and OIDN where they ran
    best, oidn = findings.against_budgets(spp_frame(runs))
    assert best.subjects == ("F", "rae") and best.detail["per_budget"] == [{"budget": 4.0, "best": "rae",
                                                                            "gap": -0.5}]
    assert oidn.detail["per_budget"] == [{"budget": 4.0, "gap": -5.0}]
    # F's headline: the best other method of Table 1 (OIDN), never F itself
    [head] = findings.headline(t1)
    assert head.subjects == ("F", "oidn") and head.verdict == "does not hold"


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
    [base] = findings.baselines(t1.reset_index())
    assert base.subjects == ("F", "dasr", "dasr_paper_loss") and "seeds" not in base.detail
    assert "does NOT hold: DASR (paper's loss) 26.00 dB (+1.00)" in render(base)
    spread = pd.DataFrame([{"row": "F", "spp": 4, "n": 3, "PSNR mean": 25.1, "PSNR std": 0.4,
                            "PSNR min": 24.6, "PSNR max": 25.4}])
    [base] = findings.baselines(t1.reset_index(), spread)
    assert base.detail["seeds"] == {"n": 3, "mean": 25.1, "std": 0.4, "min": 24.6, "max": 25.4}
    assert "lies above F's whole range" in render(base)
    spread["PSNR max"] = 26.2
    [base] = findings.baselines(t1.reset_index(), spread)
    assert "the best baseline's 26.00 dB lies within F's range" in render(base)


def test_a_sweep_split_over_two_processes_reports_one_command_that_runs_every_job(tmp_path):
    from mcd.reporting.runs import find_sweeps

    sweep = tmp_path / "seeds" / "small"
    for exp, seed in (("A", 1), ("A", 2), ("C", 1), ("C", 2)):
        d = _job(sweep, f"{exp}_s{seed}", experiment=exp)
        (d / ".hydra" / "overrides.yaml").write_text(
            f"- +sweep=seeds\n- +experiment={exp}\n- seed={seed}\n- data.test_scenes=[cbox,room0]\n"
            "- transfer.init_from=runs/${experiment}\n")  # as Hydra writes it: every task override, as typed
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
    assert runs["one_go"].code == "ccccccc" and runs["resumed"].code == "?+ccccccc"
    assert prov.wall_s == pytest.approx(510.0 + 410.0 + 1530.0)



def test_a_runs_code_is_each_segments_commit_once_a_dirty_tree_starred(tmp_path):
    segs = [{"commit": c, "dirty": d, "start_step": i * 100, "end_step": i * 100 + 100, "seconds": 1.0}
            for i, (c, d) in enumerate([("a" * 40, False), ("a" * 40, False), ("b" * 40, True)])]
    _job(tmp_path, "run", metrics={"psnr": 30.0, "experiment": "F", "budget": 4, "segments": segs})
    (run,) = find_runs([tmp_path])
    assert run.code == "aaaaaaa+bbbbbbb*"

def test_runs_that_would_share_a_record_folder_are_refused_before_anything_is_written(tmp_path):
    for machine in ("first", "second"):
        _job(tmp_path / machine / "ablation" / "small", "F_spp4", metrics={"psnr": 30.0, "experiment": "F",
                                                                           "budget": 4})
    with pytest.raises(ValueError, match="ablation/small/F_spp4"):
        make_report([tmp_path / "first", tmp_path / "second"], tmp_path / "reports", name="both", bench=None)
    assert not (tmp_path / "reports").exists()


def _speed_job(root, name, experiment, capacity, size):
    """A finished 4-spp job whose config is composed as mcd.run would (resolved_config.yaml)."""
    from omegaconf import OmegaConf

    from mcd.config.compose import compose

    d = _job(root, name, experiment=experiment, sweep="baselines",
             metrics={"psnr": 20.0, "rmse": 0.5, "experiment": experiment, "budget": 4})
    cfg = compose([f"+experiment={experiment}", f"capacity={capacity}", f"data.height={size[0]}",
                   f"data.width={size[1]}"])
    OmegaConf.save(cfg, d / "resolved_config.yaml")
    choices = f"hydra:\n  runtime:\n    choices:\n      capacity: {capacity}\n"
    (d / ".hydra" / "hydra.yaml").write_text(choices)
    return cfg


@pytest.mark.slow
def test_speed_against_error_times_each_runs_own_model_at_its_test_resolution(tmp_path, monkeypatch):
    """A point's latency and error come from one model: the run's architecture and capacity, at
    its test frames' resolution (not the bench's paper-capacity 256x256)."""
    from mcd.models import latency
    from mcd.models.complexity import complexity
    from mcd.reporting.speed import speed_frame

    cfg_a = _speed_job(tmp_path, "A", "A", "cpu", (20, 24))
    cfg_f = _speed_job(tmp_path, "F", "F", "paper", (16, 16))
    _job(tmp_path, "noisy", experiment="noisy", sweep="baselines",
         metrics={"psnr": 10.0, "experiment": "noisy", "budget": 4})
    timed = {}

    def fake(timers, **kw):
        for t in timers:
            timed[type(t.model).__name__, *t.size] = sum(p.numel() for p in t.model.parameters())
        return [7.0] * len(timers)

    monkeypatch.setattr(latency, "alternated_ms", fake)
    df = speed_frame(find_runs([tmp_path])).set_index("experiment")
    assert list(df.index) == ["A", "F"]  # the noisy input has no network to time
    assert df.loc["A", "capacity"] == "cpu" and df.loc["F", "capacity"] == "paper"
    assert (df.loc["A", "height"], df.loc["A", "width"]) == (20, 24) and df.loc["F", "width"] == 16
    assert df.loc["A", "rmse"] == 500.0 and df.loc["A", "ms_median"] == 7.0
    params = sorted(timed.values())
    assert params == sorted(round(complexity(c, 16, 16)[0] * 1e6) for c in (cfg_a, cfg_f))
    monkeypatch.undo()  # and really timed: a finite, positive median
    df = speed_frame(find_runs([tmp_path])).set_index("experiment")
    assert (df["status"] == "ok").all() and (df["ms_median"] > 0).all()
