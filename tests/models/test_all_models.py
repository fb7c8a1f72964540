"""Every registered model, baselines and FTIN's family alike, honours the VelocityModel contract."""

from __future__ import annotations

import json
from functools import lru_cache

import numpy as np
import pytest
import torch
from safetensors.torch import load_file, save_file

from ftin.models import (
    Parts,
    UnknownModelError,
    VelocityModel,
    Windows,
    create_model,
    list_models,
    model_contract,
    model_label,
)

MODEL_NAMES = list_models()
BASELINES = ("ronin_resnet", "ronin_lstm", "ronin_tcn", "tlio", "rnin", "imunet")
BATCH = 3


def default_window(name: str) -> int:
    """The default window of the model's contract (the one ``create_model(name)`` is built for)."""
    return model_contract(name).window


def smallest_window(name: str, at_least: int = 64) -> int:
    """The smallest window length >= ``at_least`` the model's contract accepts."""
    contract = model_contract(name)
    multiple = contract.multiple()
    return -(-max(contract.min_window, at_least) // multiple) * multiple  # round up to a multiple


def model_for_other_window(name: str) -> tuple[VelocityModel, int]:
    """The model built for (or simply fed) a second supported window length."""
    contract = model_contract(name)
    window = smallest_window(name)
    if window == contract.window:
        window += 32 if contract.windows is Windows.FIXED else contract.multiple()
    return create_model(name, window=window), window


def imu_batch(window: int, batch: int = BATCH, seed: int = 0) -> torch.Tensor:
    """Standard-normal windows, the scale of inputs the caller has normalised."""
    generator = torch.Generator().manual_seed(seed)
    return torch.randn(batch, 6, window, generator=generator)


def test_registry_has_every_baseline():
    assert set(BASELINES) <= set(MODEL_NAMES)


def test_every_model_has_one_label_of_its_own():
    labels = [model_label(name) for name in MODEL_NAMES]
    assert all(labels) and len(set(labels)) == len(labels)
    assert model_label("ronin_resnet") == "RoNIN ResNet" and model_label("resnet_tdl") == "ResNet + TDL"


def test_unknown_model_is_rejected_with_the_valid_names():
    with pytest.raises(UnknownModelError) as info:
        create_model("no_such_model")
    message = str(info.value)
    assert "no_such_model" in message
    for name in MODEL_NAMES:
        assert name in message


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_unknown_config_key_is_rejected(name):
    with pytest.raises((TypeError, ValueError), match="no_such_option"):
        create_model(name, no_such_option=1)


# ------------------------------------------------------------------------------ the input contract
@pytest.mark.parametrize("name", MODEL_NAMES)
def test_contract_matches_the_built_model(name):
    contract = model_contract(name)
    model = create_model(name)
    assert set(model.config) == set(contract.options)
    assert model.out_dim == contract.out_dim == contract.default("out_dim")
    assert (model.has_uncertainty, model.streams, model.train_loss) == (
        contract.uncertainty,
        contract.streams,
        contract.train_loss,
    )
    # which windows: FIXED models carry the window in their config, built for the default one
    assert ("window" in model.config) == (contract.windows is Windows.FIXED)
    if contract.windows is Windows.FIXED:
        assert model.config["window"] == contract.window
    assert model.window_multiple == contract.multiple()
    assert model.min_window == max(
        contract.min_window, contract.multiple() if contract.windows is Windows.MULTIPLE else 1
    )
    # outputs: parts per window and the default window runs
    window = contract.window
    parts = {Parts.WINDOW: 1, Parts.SUB_WINDOW: window // contract.multiple(), Parts.FRAME: window}
    assert model.check_parts(window) == model.target_parts(window) == parts[contract.parts]
    assert contract.rate_hz > 0 and contract.window_error(window) is None


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_create_model_takes_a_window_or_says_why_not(name):
    contract = model_contract(name)
    model, window = model_for_other_window(name)
    assert contract.window_error(window) is None
    assert model.check_parts(window) >= 1
    with pytest.raises(ValueError, match="window"):
        create_model(name, window=0)
    if contract.windows is Windows.MULTIPLE:
        with pytest.raises(ValueError, match=f"{name}: window must be >= .* multiple of"):
            create_model(name, window=contract.multiple() + 1)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_contract_options_a_model_does_not_take_are_dropped(name):
    contract = model_contract(name)
    model = create_model(name, window=default_window(name), out_dim=contract.out_dim)
    assert model.config == create_model(name).config  # nothing added, e.g. no window for the LSTM
    with pytest.raises((TypeError, ValueError), match="windw"):  # a misspelling is still an error
        create_model(name, windw=default_window(name))


def test_contract_of_an_unknown_model_names_the_valid_ones():
    with pytest.raises(UnknownModelError, match="valid models: .*ronin_resnet"):
        model_contract("no_such_model")
    assert model_contract("rnin").multiple({"sub_window": 25}) == 25
    assert "window" not in create_model("ronin_lstm", window=400).config


# ---------------------------------------------------------------------------------- every model
@pytest.mark.parametrize("name", MODEL_NAMES)
def test_output_shapes_at_default_and_other_window(name):
    model = create_model(name).eval()
    assert isinstance(model, VelocityModel)
    other_model, other_window = model_for_other_window(name)
    for m, window in ((model, default_window(name)), (other_model.eval(), other_window)):
        with torch.no_grad():
            out = m(imu_batch(window))
        assert out.velocity.shape == (BATCH, m.out_dim)
        if m.has_uncertainty:
            assert out.log_std is not None and out.log_std.shape == (BATCH, m.out_dim)
        else:
            assert out.log_std is None


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_window_sized_models_reject_another_length(name):
    model = create_model(name).eval()
    if "window" not in model.config:
        pytest.skip(f"{name} accepts any supported window length")
    with pytest.raises((ValueError, RuntimeError)):
        model(imu_batch(default_window(name) + 32))


@pytest.mark.parametrize("name", BASELINES)
def test_baselines_explain_input_errors(name):
    model = create_model(name).eval()
    window = default_window(name)
    with pytest.raises(ValueError, match=r"\(B, 6, L\)"):
        model(torch.zeros(2, 5, window))
    if "window" in model.config:
        with pytest.raises(ValueError, match=rf"window={window + 32}"):  # says how to rebuild
            model(torch.zeros(2, 6, window + 32))


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_backward_gives_finite_grads_for_every_parameter(name):
    torch.manual_seed(0)
    model = create_model(name).train()
    out = model(imu_batch(default_window(name), batch=4))
    loss = out.velocity.square().mean()
    if out.log_std is not None:
        loss = loss + out.log_std.mean()
    loss.backward()
    for param_name, param in model.named_parameters():
        assert param.grad is not None, f"{name}.{param_name} got no gradient"
        assert torch.isfinite(param.grad).all(), f"{name}.{param_name} has non-finite gradients"


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_no_nan_on_zeros_and_on_large_inputs(name):
    model = create_model(name)
    window = default_window(name)
    inputs = (torch.zeros(BATCH, 6, window), 50.0 * imu_batch(window, seed=1))
    for mode in (model.train, model.eval):
        mode()
        for x in inputs:
            with torch.no_grad():
                out = model(x)
            assert torch.isfinite(out.velocity).all()
            if out.log_std is not None:
                assert torch.isfinite(out.log_std).all()


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_eval_mode_is_deterministic(name):
    model = create_model(name).eval()
    x = imu_batch(default_window(name))
    with torch.no_grad():
        first, second = model(x), model(x)
    assert torch.equal(first.velocity, second.velocity)
    if first.log_std is not None:
        assert torch.equal(first.log_std, second.log_std)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_feature_taps_fill_the_dict_only_when_asked(name):
    model = create_model(name).eval()
    features: dict = {}
    with torch.no_grad():
        model(imu_batch(default_window(name)), features=features)
    assert features, f"{name} stored no feature taps"
    assert all(isinstance(v, torch.Tensor) and v.shape[0] == BATCH for v in features.values())


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_safetensors_round_trip_rebuilds_identical_model(name, tmp_path):
    torch.manual_seed(1)
    model = create_model(name)
    window = default_window(name)
    # a few training-mode passes so BatchNorm running statistics differ from their initial values
    with torch.no_grad():
        for seed in range(2):
            model.train()(imu_batch(window, batch=4, seed=seed))
    model.eval()
    path = tmp_path / f"{name}.safetensors"
    save_file(model.state_dict(), str(path))
    config = json.loads(json.dumps(model.config))  # as a checkpoint's JSON sidecar stores it
    rebuilt = create_model(name, **config)
    rebuilt.load_state_dict(load_file(str(path)))
    rebuilt.eval()
    assert rebuilt.config == model.config
    x = imu_batch(window, seed=5)
    with torch.no_grad():
        expected, actual = model(x), rebuilt(x)
    assert torch.equal(expected.velocity, actual.velocity)
    if expected.log_std is not None:
        assert torch.equal(expected.log_std, actual.log_std)


# ------------------------------------------------------------------------------- a few training steps
@lru_cache(maxsize=1)
def _simulated_sequence():
    from ftin.sim import SimConfig, simulate

    # noiseless IMU: the target is then an exact function of the input (dead reckoning from the
    # window's kinematics), so a decrease measures fitting, not noise
    return simulate(SimConfig(duration_s=40.0, rate_hz=100.0, seed=7, noise=None))


@lru_cache(maxsize=8)
def simulated_windows(window: int, out_dim: int, count: int = 8) -> tuple[torch.Tensor, torch.Tensor]:
    """``count`` world-frame windows of a simulated walk and their velocity targets (m/s)."""
    from ftin.data.windows import make_windows

    windows = make_windows(_simulated_sequence(), window, stride=max(window // 4, 1), out_dim=out_dim)
    moving = np.flatnonzero(np.linalg.norm(windows.v[:, :2], axis=1) > 0.3)
    pick = moving[np.linspace(0, len(moving) - 1, count).round().astype(int)]
    x = windows.x[pick].astype(np.float64)
    # the caller's normalisation: per-channel standardisation (acc z carries gravity)
    x = (x - x.mean(axis=(0, 2), keepdims=True)) / (x.std(axis=(0, 2), keepdims=True) + 1e-6)
    return torch.as_tensor(x, dtype=torch.float32), torch.as_tensor(windows.v[pick])


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_a_few_training_steps_reduce_the_velocity_loss(name):
    torch.manual_seed(0)
    window = smallest_window(name)  # short windows keep this test fast
    model = create_model(name, window=window).train()
    x, v = simulated_windows(window, model.out_dim)

    def batch_loss() -> float:
        torch.manual_seed(123)  # same dropout masks before and after: a like-for-like comparison
        with torch.no_grad():
            return torch.nn.functional.mse_loss(model(x).velocity, v).item()

    before = batch_loss()
    optimizer = torch.optim.Adam(model.parameters(), lr=1e-3)
    for _ in range(10):
        optimizer.zero_grad()
        loss = torch.nn.functional.mse_loss(model(x).velocity, v)  # the paper's loss
        loss.backward()
        optimizer.step()
    after = batch_loss()
    assert np.isfinite(after)
    assert after < 0.8 * before, f"{name}: loss {before:.4f} -> {after:.4f}"
