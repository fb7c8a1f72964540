"""Which alignment a comparison uses, fitted once and stated in every result (evo-like).

| ``Alignment`` | fitted on                          | what is fitted                | metrics convention |
|---------------|------------------------------------|-------------------------------|--------------------|
| ``none``      | nothing (RoNIN's raw comparison)   | -                             | ``ronin``          |
| ``start``     | the first ``start_window_s`` only  | yaw + horizontal shift (SE2)  | ``ronin``          |
| ``se2``       | the whole trajectory               | yaw + horizontal shift        | ``se2``            |
| ``se3``       | the whole trajectory               | rotation + shift              | ``se3``            |

Decisions:

* ``start`` is evo's ``--n_to_align`` and RoNIN's calibration: the two world frames are related
  once, at the start, and every later deviation counts as error. Its window is the first
  ``start_window_s`` seconds (default 10), extended until the ground truth has moved
  ``MIN_START_PATH_M`` (2 m) horizontally, because a heading cannot be fitted on a person standing
  still; a ground truth that never moves that far is fitted on its whole length.
* ``se2`` / ``se3`` are Umeyama without scale on the whole trajectory (evo's ``--align``), and
  forgive a heading drift as well as a frame offset: report them beside, not instead of, ``start``.
* When the estimate and the ground truth may live in different world frames (a user CSV with the
  phone's attitude and motion-capture positions: ``ImuSequence.meta["gt_frame"] == "unknown"``),
  ``default_alignment`` picks ``start``; readers that put the ground truth into the device's world
  frame (every dataset reader, and CSVs written by ``ftin data convert`` / ``ftin sim``) get
  ``none``, so a frame offset is never reported as error and a good frame is never re-fitted.
* The fitted transform maps the estimate into the ground-truth frame; ``AlignmentFit.gt_in_estimate_frame``
  applies its inverse to the ground truth, for drawing the truth beside an untouched prediction.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import Enum
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.types import Trajectory
from ftin.metrics.trajectory import (
    Convention,
    TrajectoryMetrics,
    _common_samples,
    evaluate_trajectory,
)
from ftin.metrics.umeyama import RigidAlignment, fit_se2, fit_se3

DEFAULT_START_WINDOW_S = 10.0
MIN_START_PATH_M = 2.0
GT_FRAME_UNKNOWN = "unknown"
GT_FRAME_DEVICE_WORLD = "device_world"


class Alignment(str, Enum):
    """How the estimate is aligned to the ground truth before it is scored (module docstring)."""

    NONE = "none"
    START = "start"
    SE2 = "se2"
    SE3 = "se3"


_CONVENTION = {
    Alignment.NONE: Convention.RONIN,
    Alignment.START: Convention.RONIN,
    Alignment.SE2: Convention.SE2,
    Alignment.SE3: Convention.SE3,
}


def convention_for(alignment: Alignment | str) -> Convention:
    return _CONVENTION[Alignment(alignment)]


def default_alignment(gt_frame: str | None) -> Alignment:
    """``start`` when the ground truth's world frame is not known to be the device's, else ``none``."""
    return Alignment.START if gt_frame == GT_FRAME_UNKNOWN else Alignment.NONE


def describe_alignment(alignment: Alignment | str, start_window_s: float = DEFAULT_START_WINDOW_S) -> str:
    alignment = Alignment(alignment)
    return {
        Alignment.NONE: "no alignment (RoNIN: the estimate starts at the ground-truth start)",
        Alignment.START: (
            f"heading and start fitted on the first {start_window_s:g} s only (at least "
            f"{MIN_START_PATH_M:g} m of ground-truth path), like evo --n_to_align"
        ),
        Alignment.SE2: "whole-trajectory SE(2) Umeyama fit (yaw + shift), like evo --align on x, y",
        Alignment.SE3: "whole-trajectory SE(3) Umeyama fit (rotation + shift), like evo --align",
    }[alignment]


@dataclass(frozen=True)
class AlignmentFit:
    """The fitted map from the estimate's frame into the ground truth's: ``p_gt ≈ R p_est + t``."""

    alignment: Alignment
    transform: RigidAlignment
    window_s: float | None = None  # seconds of the start fitted on (``start`` only)

    @property
    def heading_deg(self) -> float | None:
        """Yaw of the fitted rotation in degrees (None for ``none``: nothing was fitted)."""
        if self.alignment is Alignment.NONE:
            return None
        R = self.transform.R_gt_est.as_matrix()
        return float(np.degrees(np.arctan2(R[1, 0] - R[0, 1], R[0, 0] + R[1, 1])))

    def as_dict(self) -> dict[str, Any]:
        return {
            "alignment": self.alignment.value,
            "heading_deg": self.heading_deg,
            "align_window_s": self.window_s,
        }

    def estimate_in_gt_frame(self, est: Trajectory) -> Trajectory:
        return _moved(est, self.transform.R_gt_est, self.transform.t_gt_m)

    def gt_in_estimate_frame(self, gt: Trajectory) -> Trajectory:
        """The ground truth drawn in the estimate's frame (the inverse of the fit)."""
        R_inv = self.transform.R_gt_est.inv()
        return _moved(gt, R_inv, -R_inv.apply(self.transform.t_gt_m))


def _moved(traj: Trajectory, R: Rotation, t: np.ndarray) -> Trajectory:
    q = traj.q_world_body_wxyz
    if q is not None:
        q = frames.wxyz_from_rotation(R * frames.rotation_from_wxyz(q))
    return Trajectory(traj.t_s.copy(), R.apply(np.array(traj.p_world_m)) + t, q, traj.tracked)


def _start_count(t_s: np.ndarray, gt_m: np.ndarray, window_s: float) -> tuple[int, float]:
    steps = np.linalg.norm(np.diff(gt_m[:, :2], axis=0), axis=1)
    path = np.concatenate([[0.0], np.cumsum(steps)])
    n_time = int(np.searchsorted(t_s, t_s[0] + window_s, side="right"))
    n_path = int(np.searchsorted(path, MIN_START_PATH_M, side="left")) + 1
    n = min(max(n_time, n_path, 2), len(t_s))
    return n, float(t_s[n - 1] - t_s[0])


def fit_alignment(
    est: Trajectory,
    gt: Trajectory,
    alignment: Alignment | str = Alignment.NONE,
    start_window_s: float = DEFAULT_START_WINDOW_S,
) -> AlignmentFit:
    """Fit ``alignment`` of ``est`` to ``gt`` at the ground-truth samples both cover."""
    alignment = Alignment(alignment)
    if alignment is Alignment.NONE:
        return AlignmentFit(alignment, RigidAlignment(Rotation.identity(), np.zeros(3)))
    t_s, est_m, gt_m = _common_samples(est, gt)
    if alignment is Alignment.SE3:
        return AlignmentFit(alignment, fit_se3(est_m, gt_m))
    if alignment is Alignment.SE2:
        return AlignmentFit(alignment, fit_se2(est_m[:, :2], gt_m[:, :2]))
    if not np.isfinite(start_window_s) or start_window_s <= 0:
        raise ValueError(f"start_window_s must be a positive number of seconds, got {start_window_s}")
    n, used_s = _start_count(t_s, gt_m, start_window_s)
    return AlignmentFit(alignment, fit_se2(est_m[:n, :2], gt_m[:n, :2]), used_s)


def evaluate_aligned(
    est: Trajectory,
    gt: Trajectory,
    alignment: Alignment | str = Alignment.NONE,
    rte_window_s: float = 60.0,
    start_window_s: float = DEFAULT_START_WINDOW_S,
    smooth_s: float | None = None,
) -> tuple[TrajectoryMetrics, AlignmentFit]:
    """Metrics of ``est`` against ``gt`` under ``alignment``; the metrics name it and its heading
    (``smooth_s``: see ``evaluate_trajectory``)."""
    alignment = Alignment(alignment)
    fit = fit_alignment(est, gt, alignment, start_window_s)
    scored = fit.estimate_in_gt_frame(est) if alignment is Alignment.START else est
    metrics = evaluate_trajectory(scored, gt, convention_for(alignment), rte_window_s, smooth_s)
    metrics = replace(
        metrics, alignment=alignment.value, heading_deg=fit.heading_deg, align_window_s=fit.window_s
    )
    return metrics, fit
