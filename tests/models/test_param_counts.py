"""Baseline sizes match the reference code exactly; window-dependent sizes and config errors."""

from __future__ import annotations

import math

import pytest
import torch

from ftin.bench.profile import count_parameters
from ftin.models import create_model
from ftin.models.imunet import MIN_WINDOW as IMUNET_MIN_WINDOW
from ftin.models.imunet import feature_length

# Parameter counts of the reference implementations at 6 x 200 input: RoNIN's
# model_resnet1d / model_temporal with its default configs, TLIO's model_resnet (3 outputs), RNIN-VIO's
# ResNetLSTMSeqNet (100 Hz, 3 outputs), IMUNet's PyTorch IMUNet (2 outputs).
REFERENCE_PARAMETERS = {
    "ronin_resnet": 4_634_882,
    "ronin_lstm": 216_620,
    "ronin_tcn": 540_488,
    "tlio": 5_424_646,
    "rnin": 5_358_342,
    "imunet": 3_661_618,
}


@pytest.mark.parametrize("name", sorted(REFERENCE_PARAMETERS))
def test_default_configuration_matches_the_reference_parameter_count(name):
    assert count_parameters(create_model(name)) == REFERENCE_PARAMETERS[name]


def test_head_sizes_follow_the_window():
    # RoNIN ResNet: only the first FC layer depends on the window, 128 * L_res inputs -> 512
    l_res = {200: 7, 256: 8, 100: 4}
    base = REFERENCE_PARAMETERS["ronin_resnet"] - 128 * 7 * 512
    for window, length in l_res.items():
        assert count_parameters(create_model("ronin_resnet", window=window)) == base + 128 * length * 512
    # TLIO: both heads
    base = REFERENCE_PARAMETERS["tlio"] - 2 * 128 * 7 * 512
    assert count_parameters(create_model("tlio", window=256)) == base + 2 * 128 * 8 * 512
    # IMUNet: the custom layer (W, b) and the last linear layer scale with 400 * (L_res - 1)
    size_200 = 400 * feature_length(200)
    base = REFERENCE_PARAMETERS["imunet"] - 2 * size_200 - (size_200 * 2 + 2)
    size_400 = 400 * feature_length(400)
    assert count_parameters(create_model("imunet", window=400)) == base + 2 * size_400 + size_400 * 2 + 2


def test_sequence_models_do_not_depend_on_the_window():
    for name in ("ronin_lstm", "ronin_tcn", "rnin"):
        model = create_model(name).eval()
        assert "window" not in model.config
        for window in (200, 400):
            with torch.no_grad():
                assert model(torch.zeros(2, 6, window)).velocity.shape == (2, model.out_dim)
    # RNIN's LSTM input is set by the sub-window: 128 x L_res(sub_window) -> 4 x 256 gate rows
    smaller = create_model("rnin", sub_window=50)  # L_res 4 instead of 7
    assert count_parameters(smaller) == REFERENCE_PARAMETERS["rnin"] - 4 * 256 * 128 * 3


def test_output_dimension_changes_only_the_last_layers():
    assert (
        count_parameters(create_model("ronin_resnet", out_dim=3))
        == REFERENCE_PARAMETERS["ronin_resnet"] + 513
    )
    assert count_parameters(create_model("tlio", out_dim=2)) == REFERENCE_PARAMETERS["tlio"] - 2 * 513
    assert count_parameters(create_model("rnin", out_dim=2)) == REFERENCE_PARAMETERS["rnin"] - 2 * 257


def test_tcn_receptive_field_is_the_references():
    assert create_model("ronin_tcn").receptive_field == 253


def test_tcn_is_causal():
    model = create_model("ronin_tcn").eval()
    x = torch.randn(1, 6, 300)
    changed = x.clone()
    changed[:, :, 150:] += 1.0  # the future of frame 149
    features_a: dict = {}
    features_b: dict = {}
    with torch.no_grad():
        model(x, features=features_a)
        model(changed, features=features_b)
    a, b = features_a["per_frame_velocity"], features_b["per_frame_velocity"]
    assert torch.equal(a[:, :150], b[:, :150])
    assert not torch.equal(a[:, 150:], b[:, 150:])


def test_sequence_models_return_the_mean_of_their_per_step_velocities():
    for name, tap in (("ronin_lstm", "per_frame_velocity"), ("ronin_tcn", "per_frame_velocity"),
                      ("rnin", "per_window_velocity")):  # fmt: skip
        model = create_model(name).eval()
        features: dict = {}
        with torch.no_grad():
            out = model(torch.randn(2, 6, 300), features=features)
        torch.testing.assert_close(out.velocity, features[tap].mean(dim=1))
    assert features["per_window_velocity"].shape == (2, 3, 3)  # RNIN: 300 samples = 3 sub-windows


def test_rnin_combines_sub_window_uncertainty_as_independent_estimates():
    model = create_model("rnin").eval()
    features: dict = {}
    with torch.no_grad():
        out = model(torch.randn(2, 6, 400), features=features)
    per_window = features["per_window_log_std"]  # (B, 4, D)
    # std of the mean of 4 independent estimates: sqrt(sum sigma_i^2) / 4
    expected = 0.5 * torch.log(torch.exp(2 * per_window).sum(dim=1)) - math.log(4)
    torch.testing.assert_close(out.log_std, expected)
    with torch.no_grad():
        single = model(torch.randn(2, 6, 100), features=features)
    torch.testing.assert_close(single.log_std, features["per_window_log_std"][:, 0])


def test_imunet_window_adaptation_is_exact_at_the_reference_window():
    model = create_model("imunet").eval()
    assert model.raw_skip.weight.shape == (1, 1200) == (1, 6 * 200)
    raw = torch.randn(2, 1200)
    features = torch.randn(2, 1200)
    expected = features - model.raw_skip.weight * raw + model.raw_skip.bias
    torch.testing.assert_close(model.raw_skip(features, raw), expected, rtol=0, atol=0)
    assert IMUNET_MIN_WINDOW == 65 and feature_length(64) == 0 and feature_length(65) == 1
    with pytest.raises(ValueError, match="window must be >= 65"):
        create_model("imunet", window=64)


def test_bad_config_values_name_model_and_key():
    with pytest.raises(ValueError, match="ronin_resnet: unknown config key.*'windwo'.*valid keys: window"):
        create_model("ronin_resnet", windwo=100)
    with pytest.raises(ValueError, match="ronin_tcn: dropout"):
        create_model("ronin_tcn", dropout=1.5)
    with pytest.raises(ValueError, match="rnin: window length L=150 must be >= 100 and a multiple of 100"):
        create_model("rnin")(torch.zeros(1, 6, 150))
