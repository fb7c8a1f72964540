"""Position uncertainty along a predicted path: per-window velocity sigma -> 2x2 horizontal position
covariance per sample, in O(N) numpy (``docs/metrics.md``, "How sure is it").

Three terms, each the covariance of an error the integration carries:

- Window noise. Each interval's velocity is the mean of the windows covering it (``ftin.infer``,
  step 4), so its variance is taken as the mean of their variances. Overlapping windows read mostly
  the same samples, so their errors are not independent: the errors are treated as fully correlated
  over one window length ``tau`` and independent beyond, which sums to ``sigma^2 * dt * tau`` per
  interval (for a constant sigma: ``T / tau`` independent blocks of ``(sigma * tau)^2`` each).
  Summing the windows as independent (what the issue measured: 50 % of true positions inside the
  2-sigma ellipse where 86 % were due) ignores exactly that overlap.
- Speed scale. The distance is read off by a factor whose spread (``scale_sigma``) was measured on
  walker-held-out validation: a factor ``1 + s`` on every velocity moves the position by
  ``s * (p(t) - p(0))``, so this adds ``scale_sigma^2 d d^T`` along the displacement from the start.
- Heading. A yaw error theta(t) turns every step: the position error is ``J * integral theta(t) v dt``
  (J a quarter turn). With a gyroscope-only heading (VQF 6-D) theta drifts, ``theta = beta * t``
  (``beta`` a residual gyro bias, rad/s), which gives ``sigma_beta^2 (J m)(J m)^T`` with
  ``m = integral t v dt``; with a magnetometer (9-D) a small constant ``theta``, which gives
  ``sigma_theta^2 (J d)(J d)^T``: both across the path.

Finally the sum is multiplied by one factor fitted on position coverage (``Calibration.position_scale``).
"""

from __future__ import annotations

import numpy as np

from ftin.uncertainty.calibration import Calibration

COHERENCE_BLOCK_S = 1.0  # the windows of one second are compared with each other

# Which heading term an orientation takes: the attitude filter's name as ``ftin.infer`` reports it.
SIX_D, NINE_D = "6d", "9d"


def window_sigma(
    velocity_m_s: np.ndarray, calibration: Calibration, log_std: np.ndarray | None = None
) -> np.ndarray:
    """Per-window sigma (m/s) of each horizontal velocity axis, ``(M,)``: the model's own log-std head
    times one fitted scale where it has one, else ``a + b * |v|`` (the per-window error grows with
    speed); the same for both axes."""
    if log_std is not None and calibration.log_std_scale is not None:
        return calibration.log_std_scale * np.exp(np.asarray(log_std, dtype=np.float64)[:, :2]).mean(axis=1)
    speed = np.linalg.norm(np.asarray(velocity_m_s, dtype=np.float64)[:, :2], axis=1)
    return calibration.sigma_a + calibration.sigma_b * speed


def interval_variance(
    n: int, span_start: np.ndarray, span_end: np.ndarray, variance: np.ndarray
) -> np.ndarray:
    """``(N - 1,)`` mean variance of the spans covering each sample interval (the integration's mean
    of their velocities); an interval no span covers (the tail) keeps the last span's."""
    delta = np.zeros(n)
    np.add.at(delta, span_start, variance)
    np.add.at(delta, span_end, -variance)
    count_delta = np.zeros(n)
    np.add.at(count_delta, span_start, 1.0)
    np.add.at(count_delta, span_end, -1.0)
    total = np.cumsum(delta)[: n - 1]
    count = np.rint(np.cumsum(count_delta)[: n - 1])
    out = np.full(n - 1, float(variance[-1]) if len(variance) else 0.0)
    covered = count > 0
    out[covered] = np.maximum(total[covered] / count[covered], 0.0)
    return out


def direction_coherence(
    t_s: np.ndarray, span_start: np.ndarray, span_end: np.ndarray, velocity_m_s: np.ndarray
) -> float:
    """How much of the windows' speed survives their mean within each second: the median over
    ``COHERENCE_BLOCK_S`` blocks (by window centre) of ``|sum v| / sum |v|`` of the horizontal window
    velocities, in [0, 1]; 1 where they agree (or there are none), low where they cancel."""
    v = np.asarray(velocity_m_s, dtype=np.float64)[:, :2]
    if len(v) == 0:
        return 1.0
    t = np.asarray(t_s, dtype=np.float64)
    centre = 0.5 * (t[np.asarray(span_start)] + t[np.asarray(span_end)])
    block = np.floor((centre - centre.min()) / COHERENCE_BLOCK_S).astype(int)
    total = np.zeros((block.max() + 1, 2))
    speed = np.zeros(block.max() + 1)
    np.add.at(total, block, v)
    np.add.at(speed, block, np.linalg.norm(v, axis=1))
    moving = speed > 0
    if not moving.any():
        return 1.0
    return float(np.median(np.linalg.norm(total[moving], axis=1) / speed[moving]))


def heading_kind(orientation_filter: str | None) -> str:
    """``"9d"`` where a magnetometer held the heading, else ``"6d"`` (gyroscope alone, or not said:
    the cautious reading)."""
    return NINE_D if orientation_filter and "9" in orientation_filter else SIX_D


def path_covariance(
    t_s: np.ndarray,
    p_m: np.ndarray,
    span_start: np.ndarray,
    span_end: np.ndarray,
    sigma_m_s: np.ndarray,
    calibration: Calibration,
    *,
    heading: str = SIX_D,
    carry: str | None = None,
    window_s: float = 1.0,
    coherence: float = 1.0,
) -> np.ndarray:
    """``(N, 3)`` covariance ``[xx, xy, yy]`` (m^2) of each sample's horizontal position, zero at the
    start (module docstring). ``span_start`` / ``span_end`` index ``t_s``; ``sigma_m_s`` is one
    window's sigma per span; ``p_m`` the predicted positions (``(N, >=2)``); ``coherence`` the walk's
    ``direction_coherence``."""
    t = np.asarray(t_s, dtype=np.float64)
    n = len(t)
    cov = np.zeros((n, 3))
    if n < 2:
        return cov
    p = np.asarray(p_m, dtype=np.float64)[:, :2]
    dt = np.diff(t)
    var = interval_variance(n, np.asarray(span_start), np.asarray(span_end), np.asarray(sigma_m_s) ** 2)
    noise = np.concatenate([[0.0], np.cumsum(var * dt * window_s)])
    cov[:, 0] += noise
    cov[:, 2] += noise
    d = p - p[0]
    lost = calibration.coherence_gain * max(1.0 - coherence, 0.0)
    _add_outer(cov, d, calibration.scale_sigma_for(carry) ** 2 + lost**2)
    across = d[:, ::-1] * np.array([-1.0, 1.0])  # J d: a quarter turn
    if heading == NINE_D:
        _add_outer(cov, across, calibration.heading_sigma_rad**2)
    else:
        t_mid = 0.5 * (t[1:] + t[:-1]) - t[0]
        m = np.concatenate([np.zeros((1, 2)), np.cumsum(t_mid[:, None] * np.diff(p, axis=0), axis=0)])
        _add_outer(cov, m[:, ::-1] * np.array([-1.0, 1.0]), calibration.gyro_drift_rad_s**2)
    return cov * calibration.position_scale


def _add_outer(cov: np.ndarray, u: np.ndarray, weight: float) -> None:
    cov[:, 0] += weight * u[:, 0] * u[:, 0]
    cov[:, 1] += weight * u[:, 0] * u[:, 1]
    cov[:, 2] += weight * u[:, 1] * u[:, 1]
