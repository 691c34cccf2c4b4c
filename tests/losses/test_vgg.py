"""Loading VGG-16 feature weights from a local torchvision-format file (docs/method.md "Losses", L_p)."""

import pytest
import torch

from mcd.losses.vgg import VGGPerceptual, load_perceptual, load_vgg16_features, vgg16_features


def torchvision_state(seed=0):
    torch.manual_seed(seed)
    state = {f"features.{k}": v for k, v in vgg16_features().state_dict().items()}
    state["classifier.0.weight"] = torch.zeros(4, 4)  # torchvision files carry the classifier too
    return state


def test_layer_indices_match_torchvision():
    feats = vgg16_features()
    convs = [i for i, m in enumerate(feats) if isinstance(m, torch.nn.Conv2d)]
    assert convs == [0, 2, 5, 7, 10, 12, 14, 17, 19, 21, 24, 26, 28]
    assert len(feats) == 31 and isinstance(feats[30], torch.nn.MaxPool2d)
    assert sum(p.numel() for p in feats.parameters()) == 14_714_688  # VGG-16 "D" conv part


def test_loads_the_files_weights(tmp_path):
    state = torchvision_state()
    path = tmp_path / "vgg16-397923af.pth"
    torch.save(state, path)
    feats = load_vgg16_features(path)
    assert torch.equal(feats[28].bias, state["features.28.bias"])
    net, status = load_perceptual(str(path))
    assert status.on and str(path) in status.reason
    assert isinstance(net, VGGPerceptual) and not any(p.requires_grad for p in net.parameters())
    x = torch.rand(1, 3, 16, 16)
    assert net(x, x).item() == 0.0


def test_missing_file_turns_the_term_off_and_names_the_path(tmp_path):
    net, status = load_perceptual(str(tmp_path / "absent.pth"))
    assert net is None and not status.on and "absent.pth" in status.reason


@pytest.mark.parametrize("bad", ["keys", "shape", "garbage"])
def test_a_file_that_is_not_vgg16_is_an_error_naming_it(tmp_path, bad):
    path = tmp_path / "weights.pth"
    state = torchvision_state()
    if bad == "keys":
        state.pop("features.10.weight")
        torch.save(state, path)
    elif bad == "shape":
        state["features.0.weight"] = torch.zeros(64, 1, 3, 3)
        torch.save(state, path)
    else:
        path.write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="weights.pth"):
        load_perceptual(str(path))
