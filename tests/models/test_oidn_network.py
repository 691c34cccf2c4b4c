"""OIDN's MACs and parameters are those of the network the installed OIDN runs (docs/inference.md "OIDN's
MACs"): the replica's layer shapes equal the weights embedded in the OIDN library that ``pyoidn`` ships, and
the count follows OIDN's 16-pixel padding."""

from __future__ import annotations

import importlib.util
import re
import struct
from pathlib import Path

import pytest
import torch

from mcd.models.baselines.oidn_network import MODEL_OF_QUALITY, WIDTHS, OIDNUNet
from mcd.models.complexity import count_macs, count_params

HAS_PYOIDN = importlib.util.find_spec("pyoidn") is not None
TZA_MAGIC = b"\xd7\x41\x02"  # OIDN's tensor archive: magic 0x41D7 (little-endian), format version 2


def embedded_networks(library: bytes) -> list[dict[str, tuple[int, ...]]]:
    """The conv weight shapes (name -> shape) of every tensor archive embedded in an OIDN library file
    (the format of OIDN's ``training/tza.py``: header, tensors, then a table of name, shape, layout, type
    and offset)."""
    found = []
    for m in re.finditer(re.escape(TZA_MAGIC), library):
        start = m.start()
        table = start + struct.unpack_from("<Q", library, start + 4)[0]
        if not start < table < len(library) - 4:
            continue
        count, at, shapes = struct.unpack_from("<I", library, table)[0], table + 4, {}
        try:
            for _ in range(count):
                n = struct.unpack_from("<H", library, at)[0]
                name = library[at + 2:at + 2 + n].decode()
                at += 2 + n
                ndim = library[at]
                shape = struct.unpack_from(f"<{ndim}I", library, at + 1)
                at += 1 + 4 * ndim + ndim + 1 + 8  # shape, layout letters, type letter, offset
                shapes[name] = shape
        except (struct.error, UnicodeDecodeError):
            continue
        if shapes and all(k.endswith((".weight", ".bias")) for k in shapes):
            found.append({k: v for k, v in shapes.items() if k.endswith(".weight")})
    return found


def oidn_library() -> Path:
    import pyoidn

    libs = sorted(Path(pyoidn.__file__).parent.rglob("libOpenImageDenoise_core.so*"))
    if not libs:
        pytest.skip("pyoidn ships no libOpenImageDenoise_core here")
    return libs[0]


@pytest.mark.skipif(not HAS_PYOIDN, reason="pyoidn is not installed (the optional extra mcd[oidn])")
@pytest.mark.parametrize("model", sorted(WIDTHS))
def test_replica_has_the_shapes_of_the_weights_oidn_ships(model):
    networks = embedded_networks(oidn_library().read_bytes())
    assert networks, "no tensor archive found in the OIDN library"
    # the colour + albedo + normal networks: 9 input channels
    ours = [tuple(c.weight.shape) for c in OIDNUNet(model, 9).modules() if isinstance(c, torch.nn.Conv2d)]
    theirs = [list(n.values()) for n in networks if n.get("enc_conv0.weight", (0, 0))[1] == 9]
    assert any([tuple(s) for s in shapes] == ours for shapes in theirs), (
        f"OIDN's library has no 9-input network shaped like the replica's {model!r}: {theirs}")


class OnColour(torch.nn.Module):
    """The replica on a colour buffer repeated to 9 channels (what counting needs: shapes only)."""

    def __init__(self) -> None:
        super().__init__()
        self.net = OIDNUNet("unet")

    def required_buffers(self) -> set[str]:
        return {"c4"}

    def forward(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        return {"output": self.net(torch.cat([batch["c4"]] * 3, 1))}


def test_count_is_of_the_16_pixel_padded_image():
    with torch.device("meta"):
        model = OnColour()
    assert count_macs(model, 1080, 1920) == count_macs(model, 1088, 1920)
    assert count_macs(model, 1088, 1920) == 4 * count_macs(model, 544, 960)
    # the sum over the 16 layers of 9 x cin x cout x (1920 x 1088 / 4^scale): 261.97 GMACs
    assert count_macs(model, 1080, 1920) == 261_968_117_760


@pytest.mark.skipif(not HAS_PYOIDN, reason="pyoidn is not installed (the optional extra mcd[oidn])")
@pytest.mark.parametrize("quality", sorted(MODEL_OF_QUALITY))
def test_oidn_method_counts_the_network_of_its_quality(quality):
    from mcd.models.baselines.oidn import OIDN

    method = OIDN(4, quality)
    with torch.device("meta"):
        expected = OIDNUNet(MODEL_OF_QUALITY[quality])
    assert count_params(method) == sum(p.numel() for p in expected.parameters()) > 0
    assert count_macs(method, 64, 48) > 0
    out = method({"ref": None, "c4": torch.zeros(1, 3, 37, 29, device="meta"),
                  "albedo": torch.zeros(1, 3, 37, 29, device="meta"),
                  "normal": torch.zeros(1, 3, 37, 29, device="meta")})["output"]
    assert out.shape == (1, 3, 37, 29) and out.device.type == "meta"


def test_unknown_quality_is_refused_by_name():
    pytest.importorskip("pyoidn")
    from mcd.models.baselines.oidn import OIDN

    with pytest.raises(ValueError, match="method.quality='ultra'"):
        OIDN(4, "ultra")
