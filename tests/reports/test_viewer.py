"""The report's comparison viewer (mcd/reporting/viewer.py, docs/benchmark.md "Viewer"), on a
real report: rows A and F trained a few steps on 32x32 Mitsuba renders, then ``mcd.report``. Its data against
the runs' records, and the page in a real headless Chromium (Debian's ``chromium``, installed by
``scripts/setup.sh``, driven by Playwright): no console error, every picture resolves, only the shown stop's
pictures load, and the wipe, the synced zoom, the pan and the exposure change what is drawn. The browser test
skips only where Chromium or Playwright is missing outside CI; in CI (``CI`` set) it fails instead."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from mcd.report import make_report
from mcd.reporting import viewer
from mcd.reporting.runs import find_runs
from mcd.reporting.strips import crop_box, samples

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def report(ab_sweep, tmp_path_factory) -> tuple[Path, Path]:
    """``(report dir, sweep dir)`` of a real report of rows A and F: the session's two-job sweep on the
    sweep-to-report test's 32x32 profile, its two test frames both saved as samples (``ab_sweep``)."""
    tmp = tmp_path_factory.mktemp("viewer")
    sweep = ab_sweep / "multirun" / "ablation" / "tiny"
    out = make_report([sweep], tmp / "reports", name="t32", bench=None)
    return out, sweep


def _data(report_dir: Path) -> dict:
    text = (report_dir / "viewer" / "data.js").read_text()
    body = text[text.index("window.MCD_VIEWER = ") + len("window.MCD_VIEWER = "):].strip()
    return json.loads(body.removesuffix(";"))


def _pixels(report_dir: Path, src: str) -> np.ndarray:
    return np.asarray(Image.open(report_dir / "viewer" / src).convert("RGB"), dtype=np.float64)


@pytest.mark.slow
def test_the_viewer_holds_every_saved_frame_with_the_runs_own_metrics(report):
    out, sweep = report
    assert viewer.index_path(out) == out / "viewer" / "index.html"
    assert viewer.index_path(out.parent) is None  # a folder without a viewer
    readme = (out / "README.md").read_text()
    assert "[viewer](viewer/index.html)" in readme and "- [viewer/index.html](viewer/index.html)" in readme
    data = _data(out)
    assert data["stops"] == list(viewer.STOPS) and data["report"] == "t32"
    f_run = next(r for r in find_runs([sweep]) if r.experiment == "F")
    saved = samples(f_run)["cbox"]
    assert [(f["scene"], f["frame"]) for f in data["frames"]] == [("cbox", k) for k in sorted(saved)]
    assert len(saved) == 2  # train.sample_frames
    frames = {e: pd.read_csv(sweep / f"{e}_spp4" / "frames.csv") for e in ("A", "F")}
    for f in data["frames"]:
        assert (f["width"], f["height"], f["full"], f["crop"]) == (32, 32, [32, 32], [0, 0])
        keys = [im["key"] for im in f["images"]]
        assert keys == ["noisy", "A", "F", "reference"]  # Table 1's order: row A stands in for the U-Net
        for im in f["images"]:
            for src in im["stops"] + ([im["flip"]["src"]] if "flip" in im else []):
                assert (out / "viewer" / src).is_file(), src
            if im["key"] == "reference":
                assert "flip" not in im and all(v is None for v in im["metrics"].values())
                continue
            row = frames["F" if im["key"] == "noisy" else im["key"]].query(f"frame == {f['frame']}").iloc[0]
            prefix = "input_" if im["key"] == "noisy" else ""
            for key in viewer.METRICS:
                assert im["metrics"][key] == pytest.approx(row[prefix + key]), (im["key"], key)
            # the error map pictured is the one the run scored: its mean is the frame's FLIP
            assert im["flip"]["mean"] == pytest.approx(row[prefix + "flip"], abs=1e-6)
            # each stop is the same picture brighter
            means = [_pixels(out, src).mean() for src in im["stops"]]
            assert all(a < b for a, b in zip(means, means[1:], strict=False)), means
        assert [m["key"] for m in f["maps"]] == ["sampling_map", "kernel_index", "identity_weight"]
        for m in f["maps"]:
            assert _pixels(out, m["src"]).shape == (32, 32, 3)
    for name in ("index.html", "viewer.js", "viewer.css"):
        assert (out / "viewer" / name).read_bytes() == (viewer.PAGE_DIR / name).read_bytes()
    page = (out / "viewer" / "index.html").read_text() + (out / "viewer" / "viewer.js").read_text()
    assert "http://" not in page and "https://" not in page  # nothing from the network


@pytest.mark.slow
def test_a_large_frame_is_cut_to_its_noisiest_square(report, monkeypatch, tmp_path):
    out, sweep = report
    monkeypatch.setattr(viewer, "MAX_SIDE", 16)
    page = viewer.write(find_runs([sweep]), tmp_path, "cut")
    assert page == tmp_path / "viewer" / "index.html"
    data = _data(tmp_path)
    f_run = next(r for r in find_runs([sweep]) if r.experiment == "F")
    from mcd.data.exr import read_exr

    for f in data["frames"]:
        names = samples(f_run)["cbox"][f["frame"]]
        y, x = crop_box(read_exr(names["noisy"]), read_exr(names["reference"]), 16)
        assert (f["width"], f["height"], f["full"], f["crop"]) == (16, 16, [32, 32], [x, y])
        for im in f["images"]:
            assert _pixels(tmp_path, im["stops"][0]).shape == (16, 16, 3)
    assert [p.name for p in tmp_path.iterdir()] == ["viewer"]  # the partial folder was renamed
    # without samples the viewer is kept as it was
    assert viewer.write([], tmp_path, "cut") == tmp_path / "viewer" / "index.html"
    assert viewer.write([], tmp_path / "none", "cut") is None


@pytest.mark.slow
def test_a_report_regenerated_from_its_records_keeps_its_viewer(report):
    """The run records keep no samples: regenerating from them leaves the viewer (as the strips) and its
    link."""
    out, _ = report
    before = (out / "viewer" / "data.js").read_bytes()
    make_report([out / "runs"], out.parent, name=out.name, bench=None)
    assert (out / "viewer" / "data.js").read_bytes() == before
    assert "[viewer](viewer/index.html)" in (out / "README.md").read_text()


def _changed(a: bytes, b: bytes) -> float:
    """The share of pixels that differ between two PNG screenshots of one element."""
    import io

    x, y = (np.asarray(Image.open(io.BytesIO(v)).convert("RGB"), dtype=np.int16) for v in (a, b))
    assert x.shape == y.shape
    return float((np.abs(x - y).max(axis=-1) > 8).mean())


def _browser():
    """Playwright's sync API and Debian's chromium; skips where either is missing outside CI."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        sync_playwright = None
    needed = (("chromium (apt)", chromium), ("playwright (pip)", sync_playwright))
    missing = [what for what, ok in needed if not ok]
    if missing:
        message = f"{' and '.join(missing)} missing: scripts/setup.sh installs them"
        if os.environ.get("CI"):
            pytest.fail(message + " (CI must run the browser test)")
        pytest.skip(message)
    return sync_playwright, chromium


@pytest.mark.slow
def test_the_page_in_headless_chromium(report):
    out, _ = report
    sync_playwright, chromium = _browser()
    data = _data(out)
    f0 = data["frames"][0]
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox"])
        try:
            # tall enough that nothing scrolls: the mouse stays over the wipe
            page = browser.new_page(viewport={"width": 1300, "height": 2400})
            problems: list[str] = []
            loaded: list[str] = []
            page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}")
                    if m.type in ("error", "warning") else None)
            page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
            page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url}"))
            page.on("request", lambda r: loaded.append(r.url))
            page.goto((out / "viewer" / "index.html").as_uri())
            page.wait_for_load_state("load")

            def images_resolve() -> int:
                page.wait_for_function("[...document.images].every(i => i.complete)")
                sizes = page.evaluate(
                    "[...document.images].map(i => [i.getAttribute('src'), i.naturalWidth])")
                assert sizes and all(w > 0 for _, w in sizes), sizes
                return len(sizes)

            # the wipe's two, every colour picture and error map, the three maps
            assert images_resolve() == 2 + 4 + 3 + 3
            assert problems == []
            assert page.locator("#metrics tr").count() == 1 + 3  # header, noisy, A, F
            f_psnr = f"{f0['images'][2]['metrics']['psnr']:.2f}"
            assert f_psnr in page.locator("#metrics").inner_text()
            best = page.locator("#metrics td.best")  # the best of each metric over the three rows, in bold
            assert best.count() == len(data["metrics"])
            values = {k: [im["metrics"][k] for im in f0["images"][:3]] for k in data["metrics"]}
            tops = [max(values["psnr"]), max(values["ssim"]), min(values["rmse"]), min(values["flip"])]
            shown = sorted(best.all_inner_texts())  # the page lists them row by row
            assert shown == sorted([f"{tops[0]:.2f}", f"{tops[1]:.4f}", f"{tops[2]:#.4g}", f"{tops[3]:.4f}"])
            pictures = [u for u in loaded if u.endswith(".webp")]
            assert pictures and all("_ev+0" in u or "_flip" in u or "map" in u or "kernel" in u
                                    or "weight" in u for u in pictures), pictures  # only the shown stop

            def shot(selector: str) -> bytes:
                page.wait_for_timeout(100)
                return page.locator(selector).first.screenshot()

            wipe = "#wipeview"
            tile = "#grid .view >> nth=2"  # row A's output: not the view that gets the wheel
            half = shot(wipe)
            page.locator("#wipe").fill("0")
            right_only = shot(wipe)
            page.locator("#wipe").fill("1000")
            left_only = shot(wipe)
            # noisy input (left) against the reference (right): the whole picture changes, not just the line
            assert _changed(right_only, left_only) > 0.3, "the wipe does not change what is drawn"
            assert 0.1 < _changed(half, right_only) < _changed(left_only, right_only)
            page.select_option("#right", "F")
            page.locator("#wipe").fill("0")
            assert _changed(shot(wipe), right_only) > 0.3, "picking the right picture changes nothing"

            before_tile, before_wipe = shot(tile), shot(wipe)
            box = page.locator(wipe).bounding_box()
            page.mouse.move(box["x"] + box["width"] * 0.3, box["y"] + box["height"] * 0.4)
            page.mouse.wheel(0, -500)
            zoomed_tile, zoomed_wipe = shot(tile), shot(wipe)
            assert _changed(zoomed_wipe, before_wipe) > 0.3, "the wheel does not zoom"
            assert _changed(zoomed_tile, before_tile) > 0.3, "the zoom is not in sync across the pictures"
            scales = page.evaluate(
                "[...document.querySelectorAll('#grid .stage')].map(s => s.style.transform)")
            assert len(set(scales)) == 1 and "scale(1)" not in scales[0], scales
            page.mouse.down()
            page.mouse.move(box["x"] + box["width"] * 0.6, box["y"] + box["height"] * 0.7, steps=4)
            page.mouse.up()
            assert _changed(shot(tile), zoomed_tile) > 0.3, "dragging does not pan"
            page.click("#reset")
            assert shot(tile) == before_tile, "reset does not bring back the whole frame"

            page.locator("#exposure").fill(str(len(data["stops"]) - 1))
            images_resolve()
            srcs = page.evaluate(
                "[...document.querySelectorAll('#grid img')].map(i => i.getAttribute('src'))")
            assert sum(s.endswith(f"_ev+{data['stops'][-1]}.webp") for s in srcs) == 4, srcs
            assert _changed(shot(tile), before_tile) > 0.3, "the exposure does not change what is drawn"

            page.locator("#grid .card >> nth=2").locator(".view").first.click()
            assert page.locator("#left").input_value() == "F"
            page.select_option("#frame", "1")
            assert images_resolve() == 2 + 4 + 3 + 3
            assert problems == []
        finally:
            browser.close()


def test_hdr_extremes_black_frames_and_odd_sizes_make_finite_pictures(tmp_path):
    """Values up to 1e5 and beyond, negatives, an all-black reference and a 33x47 frame: every picture is
    written, the brightest stop saturates where it should and black stays black."""
    rng = np.random.default_rng(0)
    ref = np.zeros((33, 47, 3), np.float32)
    noisy = rng.exponential(0.5, ref.shape).astype(np.float32)
    noisy[0, 0] = 1e5
    noisy[1, 1] = 3e38
    out = noisy.copy()
    out[2, 2] = -5.0
    none = dict.fromkeys(viewer.METRICS)
    colour = [("noisy", "noisy", noisy, none), ("F", "F", out, none), ("reference", "reference", ref, none)]
    entry = viewer._frame(tmp_path, "odd", 0, colour, {})
    assert (entry["width"], entry["height"]) == (47, 33)

    def read(src: str) -> np.ndarray:
        return np.asarray(Image.open(tmp_path / src).convert("RGB"))

    assert all(read(src).shape == (33, 47, 3) for im in entry["images"] for src in im["stops"])
    brightest = read(entry["images"][0]["stops"][-1])
    assert brightest[0, 0].min() == 255 and brightest[1, 1].min() == 255
    assert read(entry["images"][1]["stops"][0])[2, 2].max() == 0  # a negative value shows black
    assert read(entry["images"][2]["stops"][-1]).max() == 0  # black at every stop
    assert all(0 <= im["flip"]["mean"] <= 1 for im in entry["images"][:2])


@pytest.mark.slow
def test_no_viewer_writes_none_and_removes_an_earlier_one(report, tmp_path):
    out, sweep = report
    shutil.copytree(out / "viewer", tmp_path / "nv" / "viewer")
    shutil.copy(out / "README.md", tmp_path / "nv" / "README.md")  # an earlier report's folder, not a user's
    make_report([sweep], tmp_path, name="nv", bench=None, with_viewer=False)
    assert not (tmp_path / "nv" / "viewer").exists() and viewer.index_path(tmp_path / "nv") is None
    assert "viewer/index.html" not in (tmp_path / "nv" / "README.md").read_text()
