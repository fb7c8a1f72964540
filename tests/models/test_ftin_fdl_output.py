"""FTIN's ``fdl_output`` option: "mixed" (default, L_fre unordered slots) vs "ordered" (L_res steps)."""

from __future__ import annotations

import json

import pytest
import torch

from ftin.models import create_model
from ftin.models.ftin_net import TINY_FTIN_KWARGS, FTINConfig
from ftin.models.layers.fdl import FDLOutput

MODES = ["mixed", "ordered"]


def _tiny(mode: str, window: int, **extra) -> dict:
    return {**TINY_FTIN_KWARGS, "window": window, "fdl_output": mode, **extra}


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("window", [100, 200])  # 1 s at 100 Hz (OxIOD) and at 200 Hz (EuRoC)
def test_shapes_and_taps_per_mode(mode: str, window: int) -> None:
    torch.manual_seed(0)
    model = create_model("ftin", **_tiny(mode, window)).eval()
    l_res = model.res_length
    steps = l_res if mode == "ordered" else TINY_FTIN_KWARGS["fre_length"]
    c_fre, c_res = TINY_FTIN_KWARGS["fre_channels"], TINY_FTIN_KWARGS["res_channels"]
    assert model.seq_shape == (c_fre, steps) and model.fdl.out_length == steps
    features: dict = {}
    with torch.no_grad():
        out = model(torch.randn(3, 6, window), features)
    assert out.velocity.shape == (3, 2) and torch.isfinite(out.velocity).all()
    shapes = {name: tuple(t.shape) for name, t in features.items()}
    d = TINY_FTIN_KWARGS["embed_dim"]
    assert shapes == {
        "resnet": (3, c_res, l_res),
        "fdl_channel_spectrum": (3, c_res // 2 + 1, l_res, d),
        "fdl_temporal_spectrum": (3, c_res, l_res // 2 + 1, d),
        "fdl": (3, c_fre, steps),
        "slstm": (3, steps, c_fre),
    }
    assert model.head.in_features == c_fre * steps  # the head flattens C_fre x steps


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("window", [100, 200])
def test_backward_reaches_every_parameter_without_nan(mode: str, window: int) -> None:
    torch.manual_seed(1)
    model = create_model("ftin", **_tiny(mode, window))
    out = model(torch.randn(4, 6, window)).velocity
    assert torch.isfinite(out).all()
    out.square().sum().backward()
    missing = [n for n, p in model.named_parameters() if p.grad is None or not torch.isfinite(p.grad).all()]
    assert not missing
    for stage in ["backbone", "fdl", "slstm", "head"]:
        assert sum(p.grad.abs().sum() for p in getattr(model, stage).parameters()) > 0, stage


@pytest.mark.parametrize("name", ["ftin", "resnet_fdl"])
@pytest.mark.parametrize("mode", MODES)
def test_config_round_trip(name: str, mode: str) -> None:
    torch.manual_seed(2)
    model = create_model(name, **_tiny(mode, 200)).eval()
    config = json.loads(json.dumps(model.config))  # what a checkpoint's JSON gives back
    assert config["fdl_output"] == mode
    rebuilt = create_model(name, **config).eval()
    rebuilt.load_state_dict(model.state_dict())  # strict
    assert rebuilt.config == model.config
    x = torch.randn(2, 6, 200)
    with torch.no_grad():
        torch.testing.assert_close(rebuilt(x).velocity, model(x).velocity)


def test_configs_without_the_key_build_the_mixed_structure() -> None:
    """Checkpoints saved before ``fdl_output`` existed: no key -> "mixed", same parameters."""
    model = create_model("ftin", **_tiny("mixed", 100))
    old_config = {k: v for k, v in model.config.items() if k != "fdl_output"}
    old = create_model("ftin", **old_config)
    assert old.fdl.output is FDLOutput.MIXED and old.config["fdl_output"] == "mixed"
    old.load_state_dict(model.state_dict())  # strict: same keys and shapes


def test_ordered_slstm_scans_the_encoder_steps_in_time_order() -> None:
    """The sLSTM's input is the ``fdl`` tap, step t = encoder step t: with FDL's temporal learner set
    to identity (``fdl_activation="identity"``: its rfft -> irfft is exact), a change of encoder
    step j changes FDL's step j only, and (the sLSTM being causal) sLSTM steps >= j only."""
    torch.manual_seed(3)
    model = create_model("ftin", **_tiny("ordered", 200, fdl_activation="identity")).eval()
    l_res = model.res_length
    assert l_res > 3
    with torch.no_grad():
        for layer in model.fdl.temporal_mlp.layers:
            layer.weight_real.copy_(torch.eye(layer.dim))
            layer.weight_imag.zero_()
            layer.bias_real.zero_()
            layer.bias_imag.zero_()
    features: dict = {}
    with torch.no_grad():
        model(torch.randn(2, 6, 200), features)
        assert features["slstm"].shape[1] == l_res
        # What the sLSTM scanned is the fdl tap with time as the step axis, in the encoder's order.
        scanned, _ = model.slstm(features["fdl"].transpose(1, 2))
        torch.testing.assert_close(scanned, features["slstm"])

        encoder = features["resnet"]  # (B, C_res, L_res)
        base_fdl = model.fdl(encoder)
        base_slstm, _ = model.slstm(base_fdl.transpose(1, 2))
        for j in range(l_res):
            bumped = encoder.clone()
            bumped[:, :, j] += 1.0
            fdl = model.fdl(bumped)  # (B, C_fre, L_res)
            fdl_changed = (fdl - base_fdl).abs().amax(dim=(0, 1)) > 1e-5
            assert fdl_changed.tolist() == [t == j for t in range(l_res)], j
            slstm, _ = model.slstm(fdl.transpose(1, 2))  # (B, L_res, C_fre)
            slstm_changed = (slstm - base_slstm).abs().amax(dim=(0, 2)) > 1e-6
            assert slstm_changed.tolist() == [t >= j for t in range(l_res)], j


def test_ordered_ignores_fre_length_and_unknown_modes_name_the_choices() -> None:
    a = create_model("ftin", **_tiny("ordered", 100, fre_length=3))
    b = create_model("ftin", **_tiny("ordered", 100, fre_length=11))
    assert a.seq_shape == b.seq_shape == (TINY_FTIN_KWARGS["fre_channels"], a.res_length)
    assert [p.shape for p in a.parameters()] == [p.shape for p in b.parameters()]
    with pytest.raises(ValueError, match=r"fdl_output must be one of 'mixed', 'ordered'.*got 'time'"):
        FTINConfig(fdl_output="time")


def _count(model: torch.nn.Module) -> int:
    return sum(p.numel() for p in model.parameters())


@pytest.mark.parametrize("window", [100, 200])
def test_parameter_counts_at_default_sizes(window: int) -> None:
    """Printed for the record (``pytest -s``); pinned as differences, so other stages may change."""
    mixed = create_model("ftin", window=window)
    ordered = create_model("ftin", window=window, fdl_output="ordered")
    counts = {
        "ftin (mixed)": _count(mixed),
        "ftin (ordered)": _count(ordered),
        "resnet_tdl": _count(create_model("resnet_tdl", window=window)),
        "ronin_resnet": _count(create_model("ronin_resnet", window=window)),
    }
    print(f"\nparameters at window {window}: " + ", ".join(f"{k} {v:,}" for k, v in counts.items()))
    cfg, l_res, hidden = mixed.cfg, mixed.res_length, mixed.cfg.head_hidden[0]
    c_res, d, c_fre, l_fre = cfg.res_channels, cfg.embed_dim, cfg.fre_channels, cfg.fre_length
    mixed_fc = (l_res * d + 1) * l_fre + (c_res + 1) * c_fre  # fc_time + fc_channel
    ordered_fc = (c_res * d + 1) * c_fre  # fc
    head_change = c_fre * (l_res - l_fre) * hidden  # the head's first layer: C_fre L_res inputs
    assert counts["ftin (ordered)"] - counts["ftin (mixed)"] == ordered_fc - mixed_fc + head_change
