"""The filter choice every door parses (``ftin.filter.choice``) and the measurement covariance a model
without a variance head gets (``FilterConfig.measurement_sigma``: fixed, or the calibrated per-window
sigma of ``ftin.uncertainty.propagate.window_sigma``)."""

from __future__ import annotations

import numpy as np
import pytest

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
    """Without a head: fixed 0.12 m/s, or a + b|v| of the checkpoint's calibration times the scale."""
    rng = np.random.default_rng(0)
    rows = rng.normal(0.0, 1.0, (walking.window, 6)).astype(np.float32)
    rows[:, 5] += 9.81  # a world-frame accelerometer reads gravity up
    fixed = NetworkVelocity(walking, FilterConfig())
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
