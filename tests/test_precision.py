"""ftin/precision.py and the ``precision`` option of ftin/infer.py: the choice at start-up and bf16
autocast around the model's forward only."""

from __future__ import annotations

import numpy as np
import pytest
import torch

import ftin.precision as precision_module
from ftin.checkpoint import load_model
from ftin.infer import predict_trajectory
from ftin.models.ftin_net import TINY_FTIN_KWARGS
from ftin.precision import BF16_FAMILIES, Precision, PrecisionSetting, choose, cpu_bf16, forward_context
from ftin.sim import SimConfig, simulate
from tests.utils.checkpoints import tiny_model_kwargs

RATE_HZ = 50.0
WINDOW = 25


@pytest.fixture(scope="module")
def walk():
    return simulate(SimConfig(duration_s=20.0, rate_hz=RATE_HZ, seed=4))


def _tiny(make_checkpoint, name: str, **kwargs):
    return load_model(make_checkpoint(name, name, rate_hz=RATE_HZ, window=WINDOW, model_kwargs=kwargs))


def _cpu(monkeypatch: pytest.MonkeyPatch, native: bool) -> None:
    monkeypatch.setattr(precision_module, "cpu_bf16", lambda: (native, "the CPU under test"))


def test_auto_picks_bf16_only_where_the_cpu_has_it_and_the_family_kept_its_accuracy(monkeypatch) -> None:
    _cpu(monkeypatch, native=False)
    without = choose("auto", "ronin_resnet")
    assert without.precision is Precision.FP32 and "auto: fp32" in without.reason
    _cpu(monkeypatch, native=True)
    family = next(iter(BF16_FAMILIES))
    assert choose(PrecisionSetting.AUTO, family).precision is Precision.BF16
    assert choose("auto").precision is Precision.BF16  # the server's own choice, before any model
    other = choose("auto", "some_family_never_measured")
    assert other.precision is Precision.FP32 and "some_family_never_measured" in other.reason
    # An explicit setting wins over the CPU and the family.
    assert choose("bf16", "some_family_never_measured").precision is Precision.BF16
    assert choose("fp32", family).precision is Precision.FP32
    with pytest.raises(ValueError):
        choose("fp16")


def test_the_cpu_check_names_what_it_found() -> None:
    native, why = cpu_bf16()
    assert isinstance(native, bool) and "torch capability" in why


def test_forward_context_autocasts_only_for_bf16() -> None:
    a, b = torch.randn(4, 8), torch.randn(8, 3)
    with forward_context(Precision.BF16):
        assert (a @ b).dtype is torch.bfloat16
    with forward_context("fp32"):
        assert (a @ b).dtype is torch.float32


@pytest.mark.parametrize("name", ["ftin", "ronin_resnet", "ronin_lstm", "ronin_tcn"])
def test_bf16_is_close_to_fp32_and_comes_back_in_float64(make_checkpoint, walk, name) -> None:
    kwargs = {**TINY_FTIN_KWARGS, "window": WINDOW} if name == "ftin" else tiny_model_kwargs(name)
    loaded = _tiny(make_checkpoint, name, **kwargs)
    fp32 = predict_trajectory(loaded, walk)
    bf16 = predict_trajectory(loaded, walk, precision="bf16")
    assert bf16.velocity_m_s.dtype == np.float64 and np.isfinite(bf16.trajectory.p_world_m).all()
    assert fp32.velocity_m_s.shape == bf16.velocity_m_s.shape
    scale = np.abs(fp32.velocity_m_s).max()
    difference = np.abs(bf16.velocity_m_s - fp32.velocity_m_s).max()
    assert 0 < difference < 0.05 * scale + 1e-3  # bf16 keeps ~3 significant digits: close, not equal
    again = predict_trajectory(loaded, walk, precision=Precision.FP32)
    np.testing.assert_array_equal(again.velocity_m_s, fp32.velocity_m_s)  # autocast left nothing behind
