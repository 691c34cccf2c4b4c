"""``mcd-denoise --reference`` zeroed an all-NaN reference without a word
(``sanitised`` was ``{}``) and printed scores as if the reference were black. A reference with no finite
value is refused before any work, naming it; NaN/Inf values in one that has some are counted in
``sanitised`` and flagged on the frame's score line. Real EXR frames and references."""

from __future__ import annotations

import numpy as np
import pytest

from mcd.denoise.cli import run
from mcd.denoise.frames import read_frame, write_layers
from tests.reliability.denoise_helpers import refused, write_frames


@pytest.mark.parametrize("damage", ["all_nan", "all_inf", "some"])
def test_a_non_finite_reference_is_refused_or_counted(tmp_path, capsys, damage):
    frames = write_frames(tmp_path / "in", n=2)
    refs = tmp_path / "refs"
    refs.mkdir()
    for f in frames:
        colour = read_frame(f, set())["colour"]
        if f.name == "f0001.exr":
            if damage == "all_nan":
                colour[:] = np.nan
            elif damage == "all_inf":
                colour[:] = np.inf
            else:  # 4 NaN and 3 Inf pixels, each in all three channels
                colour[0, :4] = np.nan
                colour[1, :3] = np.inf
        write_layers(refs / f.name, colour)
    argv = [str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--experiment", "noisy",
            "--reference", str(refs)]
    if damage != "some":
        err = refused(capsys, *argv)
        assert f"{refs / 'f0001.exr'}: every value of the reference is NaN or Inf" in err
        assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
        return
    report = run([*argv, "--no-progress"])
    assert report["sanitised"] == {"f0001.exr:reference": 21}
    rows = {r["frame"]: r for r in report["scores"]["frames"]}
    assert rows["f0001"]["reference_sanitised"] == 21 and "reference_sanitised" not in rows["f0000"]
    out = capsys.readouterr().out
    assert "frame f0001: input PSNR" in out and "(reference: 21 NaN/Inf/negative values replaced by 0)" in out
    assert "sanitised: 21 NaN/Inf/negative reference values replaced by 0 (f0001.exr:reference 21)" in out
    assert "input values replaced" not in out
