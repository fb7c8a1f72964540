"""FTIN and its ablations: shapes per window, backward, feature taps, config round trip."""

from __future__ import annotations

import json

import pytest
import torch

from ftin.models import VelocityModel, VelocityOutput, create_model, list_models
from ftin.models.ftin_net import FTIN, FTINConfig

VARIANTS = ["ftin", "resnet_fdl", "resnet_tdl", "resnet1d"]
TAPS = {
    "ftin": {"resnet", "fdl_channel_spectrum", "fdl_temporal_spectrum", "fdl", "slstm"},
    "resnet_fdl": {"resnet", "fdl_channel_spectrum", "fdl_temporal_spectrum", "fdl"},
    "resnet_tdl": {"resnet", "slstm"},
    "resnet1d": {"resnet"},
}


def test_all_variants_are_registered() -> None:
    assert set(VARIANTS) <= set(list_models())
    models = {name: create_model(name) for name in VARIANTS}
    assert all(isinstance(m, FTIN) and isinstance(m, VelocityModel) for m in models.values())
    assert {name: (m.fdl is not None, m.slstm is not None) for name, m in models.items()} == {
        "ftin": (True, True),
        "resnet_fdl": (True, False),
        "resnet_tdl": (False, True),
        "resnet1d": (False, False),
    }


@pytest.mark.parametrize("name", VARIANTS)
@pytest.mark.parametrize("window", [100, 200, 150])
def test_output_shape_per_window(name: str, window: int) -> None:
    torch.manual_seed(0)
    model = create_model(name, window=window)
    out = model(torch.randn(3, 6, window))
    assert isinstance(out, VelocityOutput)
    assert out.velocity.shape == (3, 2)
    assert out.log_std is None
    assert torch.isfinite(out.velocity).all()


def test_out_dim_three_and_channel_scan() -> None:
    model = create_model("ftin", window=100, out_dim=3, slstm_axis="channel", fre_length=8, slstm_heads=2)
    assert model(torch.randn(2, 6, 100)).velocity.shape == (2, 3)


def test_backward_reaches_every_parameter() -> None:
    torch.manual_seed(1)
    model = create_model("ftin", window=200)
    x = torch.randn(4, 6, 200)
    model(x).velocity.square().sum().backward()
    missing = [n for n, p in model.named_parameters() if p.grad is None or not torch.isfinite(p.grad).all()]
    assert not missing
    # Every stage learns something: FDL, sLSTM and head get non-zero gradients.
    for stage in ["fdl", "slstm", "head", "backbone"]:
        assert sum(p.grad.abs().sum() for p in getattr(model, stage).parameters()) > 0, stage


@pytest.mark.parametrize("name", VARIANTS)
def test_taps_present_only_when_asked(name: str) -> None:
    torch.manual_seed(2)
    model = create_model(name, window=100).eval()
    x = torch.randn(2, 6, 100)
    features: dict = {}
    with torch.no_grad():
        tapped = model(x, features).velocity
        plain = model(x).velocity
    torch.testing.assert_close(tapped, plain)  # same pass, no side effects on the result
    assert set(features) == TAPS[name]
    assert not any(t.requires_grad for t in features.values())
    assert features["resnet"].shape == (2, 128, 4)  # L = 100 -> L_res = 4
    if "fdl" in features:
        assert features["fdl_channel_spectrum"].shape == (2, 65, 4, 8)
        assert features["fdl_temporal_spectrum"].shape == (2, 128, 3, 8)
        assert features["fdl"].shape == (2, 64, 8)
    if "slstm" in features:
        assert features["slstm"].shape == ((2, 8, 64) if name == "ftin" else (2, 4, 128))


@pytest.mark.parametrize("name", VARIANTS)
def test_config_rebuilds_the_model(name: str) -> None:
    torch.manual_seed(3)
    model = create_model(name, window=200, embed_dim=4, head_hidden=(64,)).eval()
    config = json.loads(json.dumps(model.config))  # what a checkpoint's JSON gives back
    rebuilt = create_model(name, **config).eval()
    rebuilt.load_state_dict(model.state_dict())
    x = torch.randn(2, 6, 200)
    with torch.no_grad():
        torch.testing.assert_close(rebuilt(x).velocity, model(x).velocity)
    assert rebuilt.config == model.config
    assert model.config["window"] == 200 and model.out_dim == 2


def test_resnet1d_is_the_ronin_resnet_structure() -> None:
    # Same conv layers, conv1x1 512 -> 128 + BN and FC 896 -> 512 -> 512 -> 2: design.md's 4,634,882.
    model = create_model("resnet1d", window=200)
    assert sum(p.numel() for p in model.parameters()) == 4_634_882


def test_errors_name_the_problem() -> None:
    model = create_model("ftin", window=100)
    with pytest.raises(ValueError, match=r"built for window 100.*window=200"):
        model(torch.randn(1, 6, 200))
    with pytest.raises(ValueError, match=r"\(B, 6, L\)"):
        model(torch.randn(1, 3, 100))
    with pytest.raises(TypeError, match="unknown FTIN config.*'embed_size'"):
        create_model("ftin", embed_size=8)
    with pytest.raises(ValueError, match="slstm_heads \\(3\\) must divide"):
        create_model("ftin", slstm_heads=3)
    with pytest.raises(ValueError, match="slstm_axis"):
        FTINConfig(slstm_axis="diagonal")
    with pytest.raises(ValueError, match="out_dim"):
        FTINConfig(out_dim=4)
