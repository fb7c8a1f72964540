"""ftin.uncertainty's propagation against Monte Carlo: each term's covariance is what its error model,
integrated as ``ftin.infer`` integrates, really spreads to; the 95 % radius holds 95 %."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.infer import integrate_spans
from ftin.uncertainty.calibration import Calibration
from ftin.uncertainty.propagate import (
    NINE_D,
    SIX_D,
    direction_coherence,
    heading_kind,
    interval_variance,
    path_covariance,
)
from ftin.uncertainty.radius import coverage_of_radius, mahalanobis_sq, radius_holding

RATE = 50.0
T_S = np.arange(0, 60 * RATE + 1) / RATE  # one minute at 50 Hz
WINDOW = 50  # 1 s


def calibration(**terms: float) -> Calibration:
    base = {
        "sigma_a": 0.0,
        "sigma_b": 0.0,
        "scale_sigma": 0.0,
        "gyro_drift_rad_s": 0.0,
        "heading_sigma_rad": 0.0,
    }
    return Calibration(model="test", **(base | terms))


def curved_walk() -> np.ndarray:
    """``(N, 2)`` a walk at 1.2 m/s that turns slowly (a quarter turn a minute)."""
    heading = 0.3 + (np.pi / 2) * T_S / T_S[-1]
    v = 1.2 * np.column_stack([np.cos(heading), np.sin(heading)])
    steps = v[:-1] * np.diff(T_S)[:, None]
    return np.vstack([[0.0, 0.0], np.cumsum(steps, axis=0)])


def sample_cov(errors: np.ndarray) -> np.ndarray:
    """``[xx, xy, yy]`` of ``(draws, 2)`` errors around zero."""
    return np.array(
        [np.mean(errors[:, 0] ** 2), np.mean(errors[:, 0] * errors[:, 1]), np.mean(errors[:, 1] ** 2)]
    )


def test_window_noise_matches_blocks_of_one_window_integrated() -> None:
    # Windows that do not overlap, each with its own velocity error: exactly the model's "correlated
    # over one window, independent beyond" (sigma^2 * dt * window per interval).
    rng = np.random.default_rng(0)
    starts = np.arange(0, len(T_S) - WINDOW, WINDOW)
    sigma = 0.3
    draws = np.stack(
        [
            integrate_spans(
                T_S, starts, starts + WINDOW, rng.normal(0, sigma, (len(starts), 2)), np.zeros(3)
            )[-1, :2]
            for _ in range(3000)
        ]
    )
    cov = path_covariance(
        T_S,
        np.zeros((len(T_S), 2)),
        starts,
        starts + WINDOW,
        np.full(len(starts), sigma),
        calibration(),
        window_s=1.0,
    )
    assert cov[-1] == pytest.approx(sample_cov(draws), rel=0.1, abs=0.1)
    assert cov[0] == pytest.approx([0.0, 0.0, 0.0])


def test_overlapping_windows_take_the_mean_variance_of_those_covering_an_interval() -> None:
    n = 11
    span_start, span_end = np.array([0, 2, 4]), np.array([6, 8, 10])
    var = interval_variance(n, span_start, span_end, np.array([1.0, 2.0, 3.0]))
    assert var.tolist() == pytest.approx([1, 1, 1.5, 1.5, 2, 2, 2.5, 2.5, 3, 3])


def test_speed_scale_spreads_along_the_displacement() -> None:
    rng = np.random.default_rng(1)
    p = curved_walk()
    s = rng.normal(0, 0.2, 4000)
    errors = s[:, None] * (p[-1] - p[0])[None, :]  # every velocity read off by 1 + s
    cov = path_covariance(T_S, p, np.array([0]), np.array([1]), np.zeros(1), calibration(scale_sigma=0.2))
    assert cov[-1] == pytest.approx(sample_cov(errors), rel=0.1)


def test_windows_that_cancel_within_a_second_widen_the_speed_scale() -> None:
    """Direction coherence: 1 where the windows of a second agree, 0 where they cancel (a phone whose
    windows read the speed but flip direction); the speed-scale spread grows by gain x (1 - c)."""
    starts = np.arange(0, len(T_S) - WINDOW, 25)  # two windows a second
    ends = starts + WINDOW
    steady = np.tile([1.2, 0.0], (len(starts), 1))
    flipping = steady * np.where(np.arange(len(starts)) % 2 == 0, 1.0, -1.0)[:, None]
    assert direction_coherence(T_S, starts, ends, steady) == pytest.approx(1.0)
    assert direction_coherence(T_S, starts, ends, flipping) == pytest.approx(0.0, abs=1e-9)
    assert direction_coherence(T_S, starts[:0], ends[:0], steady[:0]) == 1.0  # no windows: nothing lost
    p = curved_walk()
    cal = calibration(scale_sigma=0.1)
    gained = Calibration(**cal.to_json() | {"coherence_gain": 2.0})
    span = (np.array([0]), np.array([1]), np.zeros(1))
    plain = path_covariance(T_S, p, *span, cal, coherence=0.8)
    assert path_covariance(T_S, p, *span, gained, coherence=1.0) == pytest.approx(plain)
    widened = path_covariance(T_S, p, *span, gained, coherence=0.8)  # 0.1 and 2 x 0.2 in quadrature
    assert widened[-1] == pytest.approx(plain[-1] * (0.1**2 + 0.4**2) / 0.1**2)


def test_heading_terms_turn_the_path() -> None:
    rng = np.random.default_rng(2)
    p = curved_walk()
    steps = np.diff(p, axis=0)

    def turned(theta: np.ndarray) -> np.ndarray:  # each step turned by theta (per interval)
        c, s = np.cos(theta), np.sin(theta)
        x = c * steps[:, 0] - s * steps[:, 1]
        y = s * steps[:, 0] + c * steps[:, 1]
        return np.array([x.sum(), y.sum()]) - (p[-1] - p[0])

    t_mid = 0.5 * (T_S[1:] + T_S[:-1])
    drift = np.stack([turned(b * t_mid) for b in rng.normal(0, 0.0005, 3000)])  # 6-D: rad/s
    offset = np.stack([turned(np.full(len(steps), a)) for a in rng.normal(0, 0.02, 3000)])  # 9-D: rad
    cal = calibration(gyro_drift_rad_s=0.0005, heading_sigma_rad=0.02)  # small: the terms are linear
    six = path_covariance(T_S, p, np.array([0]), np.array([1]), np.zeros(1), cal, heading=SIX_D)
    nine = path_covariance(T_S, p, np.array([0]), np.array([1]), np.zeros(1), cal, heading=NINE_D)
    assert six[-1] == pytest.approx(sample_cov(drift), rel=0.1, abs=0.01)
    assert nine[-1] == pytest.approx(sample_cov(offset), rel=0.1, abs=0.01)
    assert heading_kind("vqf-9d") == NINE_D and heading_kind("vqf-6d") == heading_kind(None) == SIX_D


def test_the_position_factor_scales_everything() -> None:
    p = curved_walk()
    one = path_covariance(
        T_S, p, np.array([0]), np.array([1]), np.ones(1), calibration(sigma_a=0.2, scale_sigma=0.1)
    )
    cal = Calibration(**calibration(sigma_a=0.2, scale_sigma=0.1).to_json() | {"position_scale": 0.5})
    half = path_covariance(T_S, p, np.array([0]), np.array([1]), np.ones(1), cal)
    assert half == pytest.approx(0.5 * one)


@pytest.mark.parametrize(
    "cov", [[[1.0, 0.0], [0.0, 1.0]], [[9.0, 2.0], [2.0, 1.0]], [[4.0, 0.0], [0.0, 1e-6]]]
)
def test_radius_holds_95_percent(cov: list[list[float]]) -> None:
    cov = np.array(cov)
    r = radius_holding(cov)
    assert coverage_of_radius(r, cov) == pytest.approx(0.95, abs=1e-3)
    draws = np.random.default_rng(3).multivariate_normal([0, 0], cov, 100_000)
    assert np.mean(np.linalg.norm(draws, axis=1) <= r) == pytest.approx(0.95, abs=0.005)
    # between a thin ellipse's 1-D quantile and the circle of the largest variance
    l_max = np.linalg.eigvalsh(cov).max()
    assert 1.959 * np.sqrt(l_max) <= r <= np.sqrt(5.992 * l_max)


def test_radius_of_nothing_and_bad_shares() -> None:
    assert radius_holding(np.zeros((2, 2))) == 0.0
    with pytest.raises(ValueError, match="share"):
        radius_holding(np.eye(2), 1.0)


def test_mahalanobis_counts_the_ellipses() -> None:
    cov = np.array([[4.0, 0.0, 1.0]])
    assert mahalanobis_sq(np.array([[2.0, 0.0]]), cov)[0] == pytest.approx(1.0)
    assert mahalanobis_sq(np.array([[0.0, 2.0]]), cov)[0] == pytest.approx(4.0)
