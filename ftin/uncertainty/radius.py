"""The radius of the circle around a 2-D Gaussian's mean that holds a given share of it: how far the
true end may lie from the predicted one (``end_radius_95_m``), from the end's 2x2 covariance."""

from __future__ import annotations

import numpy as np

_ANGLES = np.linspace(0.0, np.pi, 181)[:-1] + np.pi / 360  # half a turn suffices: the ellipse is symmetric


def coverage_of_radius(radius_m: float, cov: np.ndarray) -> float:
    """P(|x| <= r) for x ~ N(0, cov), ``cov`` 2x2: in the eigenbasis (variances l1, l2), a direction phi
    holds the mass ``1 - exp(-r^2 / (2 (l1 cos^2 phi + l2 sin^2 phi)))`` of the whitened radius."""
    l1, l2 = np.clip(np.linalg.eigvalsh(np.asarray(cov, dtype=np.float64)), 1e-18, None)
    g = l1 * np.cos(_ANGLES) ** 2 + l2 * np.sin(_ANGLES) ** 2
    return float(np.mean(1.0 - np.exp(-(radius_m**2) / (2.0 * g))))


def radius_holding(cov: np.ndarray, share: float = 0.95) -> float:
    """The exact radius (m) around the mean that holds ``share`` of N(0, cov), by bisection: at most
    the radius of the circle with the largest variance in both axes (``sqrt(-2 ln(1 - share) l_max)``),
    at least the 1-D quantile of the long axis alone (a thin ellipse)."""
    if not 0.0 < share < 1.0:
        raise ValueError(f"share must be in (0, 1), got {share}")
    l_max = float(max(np.linalg.eigvalsh(np.asarray(cov, dtype=np.float64)).max(), 0.0))
    if l_max <= 0.0:
        return 0.0
    lo, hi = 0.0, float(np.sqrt(-2.0 * np.log(1.0 - share) * l_max))  # the circle of l_max holds >= share
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if coverage_of_radius(mid, cov) < share else (lo, mid)
    return hi


def mahalanobis_sq(error: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """``(K,)`` squared Mahalanobis distances of 2-D errors ``(K, 2)`` under covariances ``(K, 3)``
    ``[xx, xy, yy]``: inside the k-sigma ellipse where it is at most k^2."""
    xx, xy, yy = cov[:, 0], cov[:, 1], cov[:, 2]
    det = np.maximum(xx * yy - xy * xy, 1e-18)
    ex, ey = error[:, 0], error[:, 1]
    return (yy * ex * ex - 2 * xy * ex * ey + xx * ey * ey) / det
