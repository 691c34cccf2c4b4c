"""``python tools/bundle_scores.py`` (docs/denoise.md, "Bundled checkpoints") on a real 32x32 store: a
bundle, OIDN and the noisy input scored on a scene's test frames, the table written between the markers."""

from __future__ import annotations

import importlib.util

import pytest

from mcd.config.methods import display_name
from tests.conftest import store32_overrides
from tools import bundle_scores


def _rows(text: str) -> dict[tuple[str, str], list[float]]:
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 6 and cells[2][:1].isdigit():
            rows[(cells[0], cells[1])] = [float(c) for c in cells[2:]]
    return rows


def test_scores_table_written_between_markers(cbox_store, tmp_path, capsys):
    _, store = cbox_store
    overrides = [*store32_overrides(store.root.parent)[1:], "data.transfer_scenes=[cbox]"]
    doc = tmp_path / "doc.md"
    doc.write_text("intro\n<!-- bundle-scores -->\nold table\n<!-- /bundle-scores -->\nrest\n")
    bundle_scores.main(["--bundle", "unet-cpu-small", "--data", "tiny", "--write", str(doc), *overrides])
    printed = capsys.readouterr().out
    text = doc.read_text()
    assert text.startswith("intro\n<!-- bundle-scores -->\n`python tools/bundle_scores.py --bundle")
    assert "old table" not in text and text.endswith("<!-- /bundle-scores -->\nrest\n")
    assert printed.strip() in text and "load average" in text and "commit" in text
    rows = _rows(text)
    noisy_input, oidn = display_name("noisy"), display_name("oidn")
    unet_row = "unet-cpu-small (trained on it)"  # trained on small, whose training scenes hold cbox
    methods = [unet_row, noisy_input] + ([oidn] if importlib.util.find_spec("pyoidn") else [])
    assert {m for s, m in rows if s == "cbox"} == set(methods)
    assert {m for s, m in rows if s == "**mean**"} <= set(methods) | {"unet-cpu-small"}
    unet, noisy = rows[("cbox", unet_row)], rows[("cbox", noisy_input)]
    assert unet[0] > noisy[0] + 1 and unet[1] > noisy[1]  # the denoiser beats its input: PSNR and SSIM
    for values in rows.values():
        assert 0 < values[1] <= 1 and values[2] >= 0 and 0 <= values[3] <= 1


def test_write_refuses_a_file_without_markers(tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text("no markers\n")
    with pytest.raises(SystemExit, match="bundle-scores"):
        bundle_scores.write_section(doc, "table\n", bundle_scores.SECTION)
    assert doc.read_text() == "no markers\n"


def test_a_profile_without_transfer_scenes_is_refused_before_any_work(tmp_path):
    with pytest.raises(SystemExit, match="data.transfer_scenes is empty"):
        bundle_scores.main(["--data", "tiny", f"paths.data_dir={tmp_path}"])
    assert not any(tmp_path.iterdir())


def test_trained_on_reads_the_record_or_the_profile_it_names():
    from omegaconf import OmegaConf

    def cfg(**data):
        return OmegaConf.create({"data": data})

    # a bundle written before its training scenes were recorded: those of the profile it names
    assert bundle_scores.trained_on(cfg(name="small")) == ["staircase2", "bathroom", "cbox",
                                                            "cornell-box-picture", "room0"]
    assert bundle_scores.trained_on(cfg(name="small", train_scenes=["cbox"])) == ["cbox"]
    assert bundle_scores.trained_on(cfg(name="gone")) == []
