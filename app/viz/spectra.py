"""Pure array helpers for the scene's plots: spectra of one window, heatmap images, error curves.

Decisions:
- The raw IMU spectrum removes each channel's mean first: gravity (≈9.8 m/s² on acc z) and gyro
  bias are DC terms that would flatten every other bin on a shared axis. Amplitudes are single-sided
  (``2 |X| / n``), in the channel's own unit.
- FDL spectra are ``|rfft|`` taps averaged over the embedding axis ``d`` (``window_taps``):
  one number per (frequency, position) cell.
- Heatmaps use a log scale (``log1p(v / median)``) normalised per image, so a few strong bins do
  not hide the structure; frequency grows upwards.
- Per-window errors are horizontal (x, y): the models predict horizontal velocity.
"""

from __future__ import annotations

import numpy as np
from matplotlib import colormaps

from ftin.data import Trajectory


def amplitude_spectrum(samples: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """``(n, C)`` samples at ``rate_hz`` -> frequencies ``(F,)`` in Hz and amplitudes ``(C, F)``."""
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 2 or len(samples) < 2:
        raise ValueError(f"samples must be (n >= 2, C), got shape {samples.shape}")
    n = len(samples)
    centred = samples - samples.mean(axis=0, keepdims=True)
    amplitude = np.abs(np.fft.rfft(centred, axis=0)).T * (2.0 / n)  # (C, F)
    return np.fft.rfftfreq(n, d=1.0 / rate_hz), amplitude


def heatmap_rgb(values: np.ndarray, target_px: tuple[int, int] = (240, 320)) -> np.ndarray:
    """``(rows, cols)`` non-negative values -> ``uint8`` RGB image, row 0 at the bottom (viridis).

    Each cell becomes a block of whole pixels, as many as fit ``target_px`` (height, width).
    """
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 2 or values.size == 0:
        raise ValueError(f"values must be a non-empty 2-D array, got shape {values.shape}")
    values = np.nan_to_num(np.abs(values))
    positive = values[values > 0]
    scale = float(np.median(positive)) if positive.size else 1.0
    logged = np.log1p(values / scale)
    top = float(logged.max())
    unit = logged / top if top > 0 else logged
    rgb = (colormaps["viridis"](unit[::-1])[..., :3] * 255).astype(np.uint8)  # (rows, cols, 3)
    ch = max(1, target_px[0] // rgb.shape[0])
    cw = max(1, target_px[1] // rgb.shape[1])
    return np.repeat(np.repeat(rgb, ch, axis=0), cw, axis=1)


def interpolate_positions(traj: Trajectory, t_s: np.ndarray) -> np.ndarray:
    """Positions ``(len(t_s), 3)`` linearly interpolated (held constant outside the trajectory)."""
    t_s = np.asarray(t_s, dtype=np.float64)
    return np.stack([np.interp(t_s, traj.t_s, traj.p_world_m[:, k]) for k in range(3)], axis=1)


def position_error_per_window(window_t_s: np.ndarray, estimate: Trajectory, truth: Trajectory) -> np.ndarray:
    """Horizontal distance between estimate and truth at each window time, in metres."""
    diff = interpolate_positions(estimate, window_t_s) - interpolate_positions(truth, window_t_s)
    return np.linalg.norm(diff[:, :2], axis=1)


def velocity_error_per_window(
    window_start_s: np.ndarray, window_end_s: np.ndarray, velocity_m_s: np.ndarray, truth: Trajectory
) -> np.ndarray:
    """Horizontal speed of (predicted - true mean velocity over each window), in m/s."""
    start = interpolate_positions(truth, window_start_s)
    end = interpolate_positions(truth, window_end_s)
    duration = np.maximum(np.asarray(window_end_s) - np.asarray(window_start_s), 1e-9)
    v_true = (end - start)[:, :2] / duration[:, None]
    return np.linalg.norm(np.asarray(velocity_m_s)[:, :2] - v_true, axis=1)


def decimate_indices(n: int, max_points: int) -> np.ndarray:
    """At most ``max_points`` evenly spread indices of ``range(n)``, always keeping the last one."""
    if n <= max_points:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, max_points).round().astype(np.int64))


def polyline_segments(points: np.ndarray) -> np.ndarray:
    """``(N, 3)`` points -> ``(N - 1, 2, 3)`` line segments joining consecutive points."""
    points = np.asarray(points, dtype=np.float32)
    return np.stack([points[:-1], points[1:]], axis=1)


def heading_error_per_window(
    window_t_s: np.ndarray,
    estimate: Trajectory,
    truth: Trajectory,
    span_s: float = 5.0,
    min_distance_m: float = 1.0,
) -> np.ndarray:
    """Signed heading (yaw) error of the walking direction, degrees in (-180, 180], per window.

    The direction of travel over ``span_s`` around each window time, predicted minus true (a span
    of a few steps: the direction of one window's velocity swings with every step). Where the
    truth moves less than ``min_distance_m`` over the span (standing) the direction is undefined:
    the last defined error is held (0 before the first), so the curve reads as the heading drift.
    """
    t = np.asarray(window_t_s, dtype=np.float64)
    lo, hi = t - 0.5 * span_s, t + 0.5 * span_s
    d_true = (interpolate_positions(truth, hi) - interpolate_positions(truth, lo))[:, :2]
    d_pred = (interpolate_positions(estimate, hi) - interpolate_positions(estimate, lo))[:, :2]
    error = np.degrees(np.arctan2(d_pred[:, 1], d_pred[:, 0]) - np.arctan2(d_true[:, 1], d_true[:, 0]))
    error = (error + 180.0) % 360.0 - 180.0
    defined = np.linalg.norm(d_true, axis=1) >= min_distance_m
    index = np.where(defined, np.arange(len(error)), -1)
    last = np.maximum.accumulate(index) if len(index) else index
    return np.where(last >= 0, error[np.maximum(last, 0)], 0.0)


def common_time_grid(duration_s: float, max_points: int = 400) -> np.ndarray:
    """Evenly spaced times from 0 to ``duration_s`` (at least 0.1 s apart, at most ``max_points``)."""
    step = max(0.1, float(duration_s) / max_points)
    return np.arange(0.0, float(duration_s) + 0.5 * step, step)


def with_cursor(
    x: np.ndarray, curves: list[np.ndarray], t_now: float
) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """Insert a vertical cursor at ``t_now`` into an aligned uPlot data set.

    ``x`` gets ``t_now`` twice, every curve its interpolated value there (no gaps); the cursor
    series is NaN everywhere but 0 and 1 at the two inserted points, for a scale fixed to [0, 1]:
    the plot draws it as a vertical line from bottom to top.
    """
    x = np.asarray(x, dtype=np.float64)
    at = int(np.searchsorted(x, t_now))
    new_x = np.concatenate([x[:at], [t_now, t_now], x[at:]])
    new_curves = []
    for y in curves:
        y = np.asarray(y, dtype=np.float64)
        value = float(np.interp(t_now, x, y)) if len(x) else 0.0
        new_curves.append(np.concatenate([y[:at], [value, value], y[at:]]))
    cursor = np.full(len(new_x), np.nan)
    cursor[at], cursor[at + 1] = 0.0, 1.0
    return new_x, new_curves, cursor
