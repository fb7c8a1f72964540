"""FTIN and its ablations: which stages each variant has, windows with the same L_res, gradients per
stage, feature taps by name and shape, error messages. What every model must do (shapes, backward,
NaN, determinism, round trip, contract) is in test_all_models.py."""

from __future__ import annotations

import pytest
import torch

from ftin.models import VelocityModel, create_model, list_models
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


def test_lengths_with_the_built_l_res_are_accepted() -> None:
    model = create_model("ftin", window=100).eval()
    with torch.no_grad():  # L = 97..100 all give L_res = 4 (module docstring of ftin_net)
        assert model(torch.randn(2, 6, 97)).velocity.shape == (2, 2)


def test_out_dim_three_and_channel_scan() -> None:
    model = create_model("ftin", window=100, out_dim=3, slstm_axis="channel", fre_length=8, slstm_heads=2)
    assert model(torch.randn(2, 6, 100)).velocity.shape == (2, 3)


def test_every_stage_gets_a_gradient() -> None:
    torch.manual_seed(1)
    model = create_model("ftin", window=200)
    model(torch.randn(4, 6, 200)).velocity.square().sum().backward()
    # Every stage learns something: FDL, sLSTM and head get non-zero gradients.
    for stage in ["fdl", "slstm", "head", "backbone"]:
        assert sum(p.grad.abs().sum() for p in getattr(model, stage).parameters()) > 0, stage


@pytest.mark.parametrize("name", VARIANTS)
def test_taps_by_name_and_shape(name: str) -> None:
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
