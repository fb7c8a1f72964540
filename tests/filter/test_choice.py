"""The filter choice every door parses (``ftin.filter.choice``) and the measurement covariance a model
without a variance head gets (``FilterConfig.measurement_sigma``: fixed, or the calibrated per-window
sigma of ``ftin.uncertainty.propagate.window_sigma``)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from ftin.checkpoint import load_model
from ftin.filter import FilterConfig
from ftin.filter.choice import filter_of, parse_filter
from ftin.filter.run import NetworkVelocity
from ftin.infer import Prediction
from ftin.uncertainty.calibration import calibration_for
from tests.utils.paths import CHECKPOINTS


@pytest.mark.parametrize(
    ("given", "parsed"), [(None, "none"), ("", "none"), ("none", "none"), ("EKF", "ekf")]
)
def test_the_choice_is_parsed(given, parsed) -> None:
    assert parse_filter(given) == parsed


def test_an_unknown_filter_names_the_field_and_the_choices() -> None:
    with pytest.raises(ValueError, match=r"filter must be one of none, ekf; got 'kalman'"):
        parse_filter("kalman")
    with pytest.raises(ValueError, match="measurement_sigma"):
        FilterConfig(measurement_sigma="learned")


def test_a_prediction_says_which_filter_made_it() -> None:
    empty = np.zeros(0)
    made = {"window_t_s": empty, "velocity_m_s": empty, "orientation_source": "vqf", "frame": "x"}
    common = {**made, "trajectory": None, "warnings": [], "features": None}
    assert filter_of(Prediction(**common, orientation_filter="ekf")) == "ekf"
    assert filter_of(Prediction(**common, orientation_filter="vqf6d")) == "none"


@pytest.fixture(scope="module")
def walking():
    return load_model(CHECKPOINTS / "ronin_resnet-walking.json")


def test_the_calibrated_measurement_sigma_grows_with_speed(walking) -> None:
    """Fixed 0.12 m/s, or a + b|v| of the checkpoint's calibration times the scale (the default has a
    head since stage three: both are asked for by name, as ``auto`` would take the head)."""
    rng = np.random.default_rng(0)
    rows = rng.normal(0.0, 1.0, (walking.window, 6)).astype(np.float32)
    rows[:, 5] += 9.81  # a world-frame accelerometer reads gravity up
    fixed = NetworkVelocity(walking, FilterConfig(measurement_sigma="fixed"))
    v, cov = fixed(rows)
    assert np.diag(cov) == pytest.approx([0.12**2] * 2)
    calibrated = NetworkVelocity(
        walking, FilterConfig(measurement_sigma="calibrated", measurement_sigma_scale=1.5)
    )
    v2, cov2 = calibrated(rows)
    np.testing.assert_allclose(v2, v)  # the same network, only its covariance changes
    c = calibration_for(walking.name)
    sigma = 1.5 * (c.sigma_a + c.sigma_b * np.linalg.norm(v[:2]))
    assert np.diag(cov2) == pytest.approx([sigma**2] * 2)
    assert cov2[0, 1] == 0.0


def test_auto_takes_a_variance_head_where_the_model_has_one(tmp_path) -> None:
    """``auto``: the head's variance (times its calibrated scale; none fitted for this one: 1) where the
    model has a head, else the fixed sigma; ``head`` on a model without one is refused; the default is
    ``fixed`` whatever the model."""
    from tests.utils.checkpoints import tiny_model_kwargs, write_checkpoint  # noqa: PLC0415

    kwargs = tiny_model_kwargs("ronin_resnet")
    headed = load_model(
        write_checkpoint(
            tmp_path / "headed", "ronin_resnet", model_kwargs={**kwargs, "uncertainty_head": True}
        )
    )
    plain = load_model(write_checkpoint(tmp_path / "plain", "ronin_resnet", model_kwargs=kwargs))
    rows = np.random.default_rng(0).normal(size=(kwargs["window"], 6)).astype(np.float32)
    network = NetworkVelocity(headed, FilterConfig(measurement_sigma="auto"))
    assert network.sigma_source == "head"
    assert NetworkVelocity(headed, FilterConfig()).sigma_source == "fixed"  # the default
    _, cov = network(rows)
    with torch.no_grad():
        out = headed.model.eval()(torch.from_numpy(rows.T[None].copy()))
    expected = np.exp(2.0 * out.log_std.numpy()[0].astype(np.float64))  # copy 0 of the four is the input
    np.testing.assert_allclose(np.diag(cov)[:2], expected, rtol=1e-5)
    assert NetworkVelocity(plain, FilterConfig(measurement_sigma="auto")).sigma_source == "fixed"
    assert NetworkVelocity(headed, FilterConfig(measurement_sigma="fixed"))(rows)[1][0, 0] == pytest.approx(
        0.12**2
    )
    with pytest.raises(ValueError, match="no variance head"):
        NetworkVelocity(plain, FilterConfig(measurement_sigma="head"))
