"""OIDN through pyoidn (docs/benchmark.md "Experiments"): no training, improves PSNR over its noisy input on a
real Mitsuba render; a clear install message when the optional package is missing."""

from __future__ import annotations

import importlib.util
import sys

import numpy as np
import pytest
import torch

from mcd.core.metrics import psnr

HAS_PYOIDN = importlib.util.find_spec("pyoidn") is not None


@pytest.fixture(scope="module")
def cbox_frame() -> dict[str, np.ndarray]:
    """The vendored Cornell box at 40x40: 4 spp colour, 4 spp G-buffers, 512 spp reference (box filter)."""
    from mcd.data.mitsuba_env import select_variant

    select_variant("auto")
    import mitsuba as mi

    from mcd.data.renderer import SceneRenderer
    from mcd.data.scenes import VENDORED_DIR

    scene = mi.load_file(str(VENDORED_DIR / "cbox" / "scene.xml"), resx=40, resy=40, max_depth=6)
    to_world = np.array(mi.traverse(scene.sensors()[0])["to_world"].matrix, dtype=np.float64).reshape(4, 4)
    r = SceneRenderer(scene, 40, 40, fov=39.3077)
    r.set_camera(to_world)
    return {"c4": r.color(4, seed=11), "ref": r.color(512, seed=12), **r.gbuffer(4, seed=13)}


def chw(a: np.ndarray) -> torch.Tensor:
    return torch.from_numpy(a).permute(2, 0, 1)[None].contiguous()


@pytest.mark.skipif(not HAS_PYOIDN, reason="pyoidn is not installed (optional: pip install 'mcd[oidn]')")
def test_oidn_improves_psnr_over_its_noisy_input(cbox_frame: dict[str, np.ndarray]) -> None:
    from mcd.models.baselines.oidn import OIDN

    model = OIDN(4)
    assert model.required_buffers() == {"c4", "albedo", "normal"}
    assert sum(p.numel() for p in model.parameters()) == 0
    x = {k: chw(v) for k, v in cbox_frame.items() if k != "ref"}
    out = model(x)["output"]
    assert out.shape == (1, 3, 40, 40) and out.dtype == torch.float32 and torch.isfinite(out).all()
    den = out[0].permute(1, 2, 0).numpy()
    noisy_psnr, oidn_psnr = psnr(cbox_frame["c4"], cbox_frame["ref"]), psnr(den, cbox_frame["ref"])
    assert oidn_psnr > noisy_psnr + 2.0, f"OIDN {oidn_psnr:.2f} dB vs noisy {noisy_psnr:.2f} dB"


def test_missing_pyoidn_names_the_install_command(monkeypatch: pytest.MonkeyPatch) -> None:
    from mcd.models.baselines.oidn import OIDN

    monkeypatch.setitem(sys.modules, "pyoidn", None)  # makes `import pyoidn` raise ImportError
    with pytest.raises(ImportError, match=r"pip install 'mcd\[oidn\]'"):
        OIDN(4)

