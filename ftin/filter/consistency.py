"""Is the filter honest about its errors? Tilt error against a reference orientation, its NEES, and
the chi-square bounds the NEES and NIS are read against (``docs/filter.md``, "Consistency").

The tilt error is read from gravity directions alone (the reference's up axis seen from the
estimate's body), so a heading difference between the two worlds never enters it.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from ftin.data import frames


def tilt_error_vector(q_est_wxyz: np.ndarray, q_true_wxyz: np.ndarray) -> np.ndarray:
    """``(N, 2)``: the world x, y components of the rotation error ``dtheta`` (``R_true = Exp(dtheta)
    R_est``, heading set aside), from the true up axis expressed in the estimate's world."""
    up = np.array([0.0, 0.0, 1.0])
    body_up = frames.rotation_from_wxyz(q_true_wxyz).inv().apply(up)  # true up in the body frame
    w = frames.rotation_from_wxyz(q_est_wxyz).apply(body_up)  # ~ e_z - dtheta x e_z
    return np.column_stack([w[:, 1], -w[:, 0]])


def tilt_error_deg(q_est_wxyz: np.ndarray, q_true_wxyz: np.ndarray) -> np.ndarray:
    """``(N,)`` angle between the estimate's and the reference's gravity direction, in degrees."""
    up = np.array([0.0, 0.0, 1.0])
    u_est = frames.rotation_from_wxyz(q_est_wxyz).inv().apply(up)
    u_true = frames.rotation_from_wxyz(q_true_wxyz).inv().apply(up)
    return np.degrees(np.arccos(np.clip(np.sum(u_est * u_true, axis=1), -1.0, 1.0)))


def tilt_nees(q_est_wxyz: np.ndarray, q_true_wxyz: np.ndarray, tilt_cov: np.ndarray) -> np.ndarray:
    """``(N,)`` NEES of the tilt (2 dof): ``e^T P^-1 e`` with the filter's tilt covariance ``(N, 2, 2)``."""
    e = tilt_error_vector(q_est_wxyz, q_true_wxyz)
    return np.einsum("ni,ni->n", e, np.linalg.solve(tilt_cov, e[..., None])[..., 0])


def chi2_bounds(dof: int, samples: int = 1, level: float = 0.95) -> tuple[float, float]:
    """Two-sided ``level`` bounds on the mean of ``samples`` independent chi-square(``dof``) values."""
    tail = (1.0 - level) / 2.0
    total = dof * samples
    return float(chi2.ppf(tail, total) / samples), float(chi2.ppf(1.0 - tail, total) / samples)


def fraction_within(values: np.ndarray, dof: int, level: float = 0.95) -> float:
    """The share of single values inside their two-sided ``level`` chi-square(``dof``) bounds (a
    consistent filter keeps about ``level`` of them there)."""
    low, high = chi2_bounds(dof, 1, level)
    values = np.asarray(values, dtype=np.float64)
    return float(np.mean((values >= low) & (values <= high))) if len(values) else float("nan")
