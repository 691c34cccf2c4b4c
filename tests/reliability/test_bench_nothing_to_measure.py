"""Campaign 8 (docs/reliability.md, "Campaign 8, part 2"): ``python -m mcd.bench`` refuses, before any work,
what would measure nothing or fail late. ``speed --devices cuda`` on a machine without CUDA (and an empty
``--methods``) measured nothing, exit 0, and replaced ``--out`` (an earlier bench's CSV) with an empty table
and its README; an unknown ``--methods`` wrote a row of Hydra's error. ``loader`` checked none of its
numbers: ``--crop`` above the frame, ``--frames`` too few for a clip, ``--width 0``, an unknown
``--experiment`` ended in tracebacks, and ``--seconds -1`` was taken."""

from __future__ import annotations

import pytest
import torch

from mcd.bench import loader, speed


@pytest.mark.parametrize(("argv", "message"), [
    (["--devices", "cuda"], "--devices 'cuda': torch sees no CUDA device here, so nothing would be measured"),
    (["--devices", ","], "--devices ',': none given, so nothing would be measured"),
    (["--methods", ","], "--methods ',': none given, so nothing would be measured"),
    (["--methods", "noisy,nosuch"], "--methods: no experiment nosuch (conf/experiment: A, B"),
])
def test_speed_that_would_measure_nothing_is_refused_and_keeps_the_csv(tmp_path, capsys, monkeypatch, argv,
                                                                       message):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)  # as on a machine without a GPU
    out = tmp_path / "bench" / "bench.csv"
    out.parent.mkdir()
    out.write_text("method,device,ms_median\nF,cpu,12.5\n")  # an earlier bench's table
    (out.parent / "README.md").write_text(f"{speed.README_TITLE}\n\nthe earlier bench\n")
    before = {p.name: p.read_bytes() for p in out.parent.iterdir()}
    with pytest.raises(SystemExit) as stop:
        speed.main(["--methods", "noisy", "--synthetic", "--sizes", "16x16", "--out", str(out), *argv])
    assert stop.value.code == 2 and message in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in out.parent.iterdir()} == before


@pytest.mark.parametrize(("argv", "message"), [
    (["--width", "64", "--height", "64", "--crop", "128"], "--crop 128 is larger than the 64x64 frames"),
    (["--frames", "3", "--clip-len", "9"], "--frames 3: one test frame and one clip of --clip-len 9 need"),
    (["--width", "0"], "argument --width: 0 is not an integer from 1"),
    (["--seconds", "-1"], "argument --seconds: -1 is not a finite number above 0"),
    (["--experiment", "nosuch"], "--experiment nosuch: no such experiment (conf/experiment: A, B"),
    (["--capacity", "nosuch"], "--capacity nosuch: no such capacity profile (conf/capacity: cpu, paper)"),
])
def test_loader_refuses_bad_numbers_and_names_before_writing_its_store(tmp_path, capsys, argv, message):
    folder = tmp_path / "stores"
    with pytest.raises(SystemExit) as stop:
        loader.main(["--dir", str(folder), "--seconds", "0.1", *argv])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and message in err and "Traceback" not in err
    assert not folder.exists()
