"""Rigid (rotation + translation, no scale) alignment of an estimated trajectory to ground truth.

Both fits are the closed-form least-squares solution of Umeyama / Horn without scale: subtract the
centroids, find the rotation that best maps the centred estimate onto the centred ground truth, and
take the translation that maps the rotated estimate centroid onto the ground-truth centroid.

- SE(2): a yaw-only rotation of the horizontal x, y positions. Solved in closed form (the angle
  whose cosine / sine are the summed dot / cross products of the centred points) rather than by a
  3-D fit on z = 0 points, because a 3-D fit may pick a 180° roll that mirrors the plane.
- SE(3): the Wahba / Kabsch rotation from ``scipy.spatial.transform.Rotation.align_vectors``, which
  always returns a proper rotation (never a reflection).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation


@dataclass(frozen=True)
class RigidAlignment:
    """``p_gt ≈ R_gt_est · p_est + t_gt_m``; a yaw-only rotation and zero z-shift for SE(2)."""

    R_gt_est: Rotation
    t_gt_m: np.ndarray  # (3,)

    def apply(self, p_est_m: np.ndarray) -> np.ndarray:
        """Map (N, 2) or (N, 3) estimated positions into the ground-truth frame (a new array)."""
        # A fresh copy: scipy's apply rejects read-only buffers, and callers' arrays may be read-only.
        p = np.array(p_est_m, dtype=np.float64)
        width = p.shape[1]
        p3 = np.column_stack([p, np.zeros(len(p))]) if width == 2 else p
        return (self.R_gt_est.apply(p3) + self.t_gt_m)[:, :width]


def fit_se2(est_xy_m: np.ndarray, gt_xy_m: np.ndarray) -> RigidAlignment:
    """Yaw + horizontal shift that best maps ``est_xy_m`` onto ``gt_xy_m`` (both (N, 2))."""
    est, gt = _check_pair(est_xy_m, gt_xy_m, width=2)
    est_c = est - est.mean(axis=0)
    gt_c = gt - gt.mean(axis=0)
    # Minimising sum |gt_c - R(yaw) est_c|^2 over yaw gives tan(yaw) = sum(cross) / sum(dot).
    dot = float(np.sum(est_c[:, 0] * gt_c[:, 0] + est_c[:, 1] * gt_c[:, 1]))
    cross = float(np.sum(est_c[:, 0] * gt_c[:, 1] - est_c[:, 1] * gt_c[:, 0]))
    R_gt_est = Rotation.from_euler("z", np.arctan2(cross, dot))
    t = np.zeros(3)
    t[:2] = gt.mean(axis=0) - R_gt_est.apply(np.append(est.mean(axis=0), 0.0))[:2]
    return RigidAlignment(R_gt_est, t)


def fit_se3(est_m: np.ndarray, gt_m: np.ndarray) -> RigidAlignment:
    """Rotation + shift that best maps ``est_m`` onto ``gt_m`` (both (N, 3))."""
    est, gt = _check_pair(est_m, gt_m, width=3)
    est_mean, gt_mean = est.mean(axis=0), gt.mean(axis=0)
    with warnings.catch_warnings():
        # Collinear or planar paths leave a rotation about the line free; every optimum gives the
        # same residual, so scipy's "not uniquely defined" warning says nothing about the metric.
        warnings.filterwarnings("ignore", message="Optimal rotation is not uniquely", category=UserWarning)
        R_gt_est, _ = Rotation.align_vectors(gt - gt_mean, est - est_mean)
    return RigidAlignment(R_gt_est, gt_mean - R_gt_est.apply(est_mean))


def _check_pair(est_m: np.ndarray, gt_m: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
    est = np.asarray(est_m, dtype=np.float64)
    gt = np.asarray(gt_m, dtype=np.float64)
    for name, p in (("est_m", est), ("gt_m", gt)):
        if p.ndim != 2 or p.shape[1] != width:
            raise ValueError(f"{name} must have shape (N, {width}) for this alignment, got {p.shape}")
    if est.shape != gt.shape:
        raise ValueError(f"est_m has shape {est.shape} but gt_m has shape {gt.shape}; they must match")
    if len(est) < 2:
        raise ValueError(f"alignment needs at least 2 positions, got {len(est)}")
    return est, gt
