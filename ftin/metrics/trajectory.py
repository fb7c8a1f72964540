"""Trajectory error metrics under a stated convention: the array functions and ``evaluate_trajectory``,
which scores every registered metric (``ftin.metrics.registry``, defined in ``ftin.metrics.definitions``).

A convention fixes the axes and the alignment of the estimate; the array functions ``ate`` / ``rte``
also follow its aggregate, while ``evaluate_trajectory`` reports both ATE conventions by name (the
headline RoNIN per-axis RMS as ``ate``, evo's Euclidean RMSE as ``ate_euclidean``):

| convention    | axes          | alignment of the estimate       | ``ate()`` / ``rte()`` aggregate    |
|---------------|---------------|---------------------------------|------------------------------------|
| ``RONIN``     | x, y          | none                            | RMSE over all N x 2 coordinates    |
| ``EUCLIDEAN`` | all given     | none                            | RMSE of per-sample Euclidean norms |
| ``SE2``       | x, y          | yaw + shift (Umeyama, no scale) | RMSE of per-sample Euclidean norms |
| ``SE3``       | x, y, z       | rotation + shift (no scale)     | RMSE of per-sample Euclidean norms |

Decisions:
- RoNIN (the default, as the paper's baselines report): the estimate is expected to be integrated
  from the ground-truth start position (the inference code does that); the metric applies no
  translation, so a start offset counts as error. Its ATE is ``sqrt(mean((est - gt)^2))`` over the
  N x 2 coordinates, which equals the Euclidean RMSE divided by sqrt 2.
- RTE is the RMSE of displacement differences ``(est[i+k] - est[i]) - (gt[i+k] - gt[i])`` over every
  start i, with ``k = round(window_s * rate_hz)`` and the rate taken from the median sample interval
  of ``t_s``, so 60 s is 6000 samples at 100 Hz and 12000 at 200 Hz (RoNIN's code hard-codes 12000,
  which is 120 s at 100 Hz). A sequence with fewer than ``k + 1`` samples uses its whole-sequence
  drift (k = N - 1) scaled by ``window_s / duration_s``.
- PDE is ``|est[end] - gt[end]| / ground-truth path length`` on the convention's axes (horizontal
  for RONIN and SE2) and, for the aligned conventions, on the aligned estimate. It is a ratio, not
  a percentage.
- ``evaluate_trajectory`` evaluates at the ground-truth timestamps: when the estimate has other
  timestamps it is linearly interpolated onto the ground-truth samples inside the time span both
  cover (never extrapolated), because the reference defines where errors are measured and an
  estimate is often sparser (one position per window) than the ground truth.
- All functions are pure: inputs are read, never written.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from ftin.data.types import Trajectory
from ftin.metrics.definitions import (
    HEADLINE,
    MIN_PATH_FOR_RATIO_M,
    compared_path_m,
    drift_ratio,
    euclidean_rmse,
    horizontal_length_m,
    per_axis_rms,
    relative_error,
)
from ftin.metrics.registry import Comparison, get_metric, list_metrics, metric_names
from ftin.metrics.umeyama import fit_se2, fit_se3

# Timestamps closer than this are the same instant (float noise from readers and resampling).
_SAME_TIME_TOL_S = 1e-6


class Convention(str, Enum):
    """How trajectories are compared; see the module docstring and ``describe``."""

    RONIN = "ronin"
    EUCLIDEAN = "euclidean"
    SE2 = "se2"
    SE3 = "se3"


_HORIZONTAL = (Convention.RONIN, Convention.SE2)


@dataclass(frozen=True)
class TrajectoryMetrics:
    """A scored comparison: every registered metric by name (``ftin.metrics.registry``; None where
    undefined), and how it was scored. ``m.ate`` / ``m["ate"]`` read one value."""

    values: dict[str, float | None]
    convention: Convention
    rte_window_s: float = 60.0
    smooth_s: float | None = None  # seconds the paths were smoothed over before their lengths
    # Set by ``ftin.metrics.alignment_modes.evaluate_aligned``: the alignment (``Alignment`` value), the
    # fitted heading of the estimate into the ground-truth frame (deg; None when nothing was fitted)
    # and, for "start", the seconds of the start it was fitted on.
    alignment: str | None = None
    heading_deg: float | None = None
    align_window_s: float | None = None

    def __getattr__(self, name: str) -> float | None:
        values = self.__dict__.get("values")
        if values is not None and name in metric_names():
            return values.get(name)
        raise AttributeError(f"{type(self).__name__} has no attribute or metric {name!r}")

    def __getitem__(self, name: str) -> float | None:
        get_metric(name)  # a clear KeyError for a name that is no metric
        return self.values.get(name)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready values: every metric by name, then the convention as its string value."""
        out: dict[str, Any] = {
            **self.values,
            "convention": self.convention.value,
            "rte_window_s": self.rte_window_s,
        }
        if self.alignment is not None:
            out.update(
                alignment=self.alignment, heading_deg=self.heading_deg, align_window_s=self.align_window_s
            )
        return out


def ate(est_m: np.ndarray, gt_m: np.ndarray, convention: Convention = Convention.RONIN) -> float:
    """Absolute trajectory error in metres of (N, 2|3) positions sampled at the same instants."""
    convention = Convention(convention)
    est, gt = _prepare(est_m, gt_m, convention)
    return _rmse(est - gt, convention)


def rte(
    est_m: np.ndarray,
    gt_m: np.ndarray,
    t_s: np.ndarray,
    window_s: float = 60.0,
    convention: Convention = Convention.RONIN,
) -> float:
    """Relative trajectory error in metres over ``window_s`` windows (rate from ``t_s``)."""
    convention = Convention(convention)
    est, gt = _prepare(est_m, gt_m, convention)
    return _relative_error(est, gt, _check_times(t_s, len(est)), window_s, convention)


def pde(est_m: np.ndarray, gt_m: np.ndarray, convention: Convention = Convention.RONIN) -> float:
    """Position drift error: final position error / ground-truth path length (a ratio)."""
    convention = Convention(convention)
    est, gt = _prepare(est_m, gt_m, convention)
    return _drift_ratio(est, gt)


def horizontal_path_length(p_m: np.ndarray) -> float:
    """Length in metres of the horizontal (x, y) polyline through ``(N, 2|3)`` positions."""
    return horizontal_length_m(_check_positions("p_m", p_m))


def path_length_ratio(
    est_m: np.ndarray, gt_m: np.ndarray, t_s: np.ndarray | None = None, smooth_s: float | None = None
) -> float | None:
    """Predicted / true horizontal path length; ``None`` when the truth walks less than 0.5 m.

    With ``t_s`` and ``smooth_s`` both paths are first smoothed over ``smooth_s`` seconds, the
    model's window (``ftin.metrics.definitions``). Alignment cannot change it (rigid motions keep
    lengths), so it reads the same under every convention: 1 is the right distance, 0 a predictor
    that never moves.
    """
    est, gt = _check_positions("est_m", est_m), _check_positions("gt_m", gt_m)
    if t_s is None:
        t_s, smooth_s = np.arange(len(gt), dtype=np.float64), None
    true_length = compared_path_m(gt, t_s, smooth_s)
    if true_length < MIN_PATH_FOR_RATIO_M:
        return None
    return compared_path_m(est, t_s, smooth_s) / true_length


def stand_still(gt: Trajectory) -> Trajectory:
    """The predictor that never moves: every position is the ground-truth start (the baseline row)."""
    p = np.repeat(np.asarray(gt.p_world_m[:1], dtype=np.float64), len(gt.t_s), axis=0)
    return Trajectory(np.array(gt.t_s, dtype=np.float64), p)


def evaluate_trajectory(
    est: Trajectory,
    gt: Trajectory,
    convention: Convention = Convention.RONIN,
    rte_window_s: float = 60.0,
    smooth_s: float | None = None,
) -> TrajectoryMetrics:
    """Every registered metric of ``est`` against ``gt`` at the ground-truth timestamps they share;
    ``smooth_s`` (the model's window, s) smooths both paths before their lengths are compared."""
    convention = Convention(convention)
    t_s, est_m, gt_m = _common_samples(est, gt)
    est_p, gt_p = _prepare(est_m, gt_m, convention)
    comparison = Comparison(t_s, est_p, gt_p, est_m, gt_m, float(rte_window_s), smooth_s)
    values = {m.name: _value(m.compute(comparison)) for m in list_metrics()}
    return TrajectoryMetrics(values, convention, float(rte_window_s), smooth_s)


def _value(value: float | None) -> float | None:
    return None if value is None else float(value)


def mean_metrics(metrics: Sequence[TrajectoryMetrics]) -> TrajectoryMetrics:
    """Mean of each metric over sequences (each sequence weighs the same, as the paper's tables);
    a metric undefined for some sequences is the mean of the others (None if undefined for all)."""
    if len(metrics) == 0:
        raise ValueError("mean_metrics needs at least one TrajectoryMetrics, got an empty list")
    first = metrics[0]
    for i, m in enumerate(metrics):
        if m.convention != first.convention or m.rte_window_s != first.rte_window_s:
            raise ValueError(
                f"metrics[{i}] uses convention {m.convention.value!r} with a {m.rte_window_s:g} s RTE "
                f"window but metrics[0] uses {first.convention.value!r} with {first.rte_window_s:g} s; "
                "only metrics of one convention and window can be averaged"
            )
    names = [n for n in metric_names() if any(n in m.values for m in metrics)]
    return TrajectoryMetrics(
        {n: _mean_or_none([m.values.get(n) for m in metrics]) for n in names},
        first.convention,
        first.rte_window_s,
        first.smooth_s,
        alignment=first.alignment if all(m.alignment == first.alignment for m in metrics) else None,
    )


def _mean_or_none(values: Sequence[float | None]) -> float | None:
    known = [v for v in values if v is not None]
    return float(np.mean(known)) if known else None


def describe(convention: Convention = Convention.RONIN, rte_window_s: float = 60.0) -> str:
    """The sentence stating the convention, for the header or footer of every table: which axes,
    which alignment, the headline convention (once) and the RTE window."""
    convention = Convention(convention)
    w = f"{rte_window_s:g} s"
    lead, axes = {
        Convention.RONIN: (
            "RoNIN convention: no alignment (the estimate starts at the ground-truth start)",
            "horizontal x, y",
        ),
        Convention.EUCLIDEAN: ("Euclidean convention: no alignment", "x, y, z"),
        Convention.SE2: (
            "SE(2)-aligned convention: the estimate is first rotated about z and shifted "
            "(Umeyama, no scale) to best fit the ground truth",
            "horizontal x, y",
        ),
        Convention.SE3: (
            "SE(3)-aligned convention: the estimate is first rotated and shifted "
            "(Umeyama, no scale) to best fit the ground truth",
            "x, y, z",
        ),
    }[convention]
    return (
        f"{lead}; errors over {axes} in metres. {HEADLINE} RTE over every {w} window (sequences "
        f"shorter than {w}: whole-sequence drift scaled by {w} / duration); PDE = final position error "
        "/ ground-truth path length; path ratio = predicted / true horizontal path, both smoothed over "
        "the model's window."
    )


# --- internals -------------------------------------------------------------------------------------


def _prepare(est_m: Any, gt_m: Any, convention: Convention) -> tuple[np.ndarray, np.ndarray]:
    """Validated copies on the convention's axes, the estimate aligned where the convention says."""
    est = _check_positions("est_m", est_m)
    gt = _check_positions("gt_m", gt_m)
    if est.shape != gt.shape:
        raise ValueError(f"est_m has shape {est.shape} but gt_m has shape {gt.shape}; they must match")
    if len(est) < 2:
        raise ValueError(f"trajectory metrics need at least 2 samples, got {len(est)}")
    if convention in _HORIZONTAL:
        est, gt = est[:, :2], gt[:, :2]
    elif convention is Convention.SE3 and est.shape[1] != 3:
        raise ValueError(f"the SE3 convention needs (N, 3) positions, got {est.shape}")
    if convention is Convention.SE2:
        est = fit_se2(est, gt).apply(est)
    elif convention is Convention.SE3:
        est = fit_se3(est, gt).apply(est)
    return est, gt


def _check_positions(name: str, value: Any) -> np.ndarray:
    p = np.asarray(value, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise ValueError(f"{name} must have shape (N, 2) or (N, 3) positions in metres, got {p.shape}")
    bad = np.flatnonzero(~np.isfinite(p).all(axis=1))
    if len(bad):
        raise ValueError(f"{name} has a non-finite value in row {bad[0]} ({len(bad)} rows in all)")
    return p


def _check_times(t_s: Any, n: int, name: str = "t_s") -> np.ndarray:
    t = np.asarray(t_s, dtype=np.float64)
    if t.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},) to match the positions, got {t.shape}")
    if not np.isfinite(t).all():
        raise ValueError(f"{name} has a non-finite value in row {np.flatnonzero(~np.isfinite(t))[0]}")
    steps = np.diff(t)
    if (steps <= 0).any():
        row = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise ValueError(f"{name} must increase strictly; row {row} ({t[row]} s) follows {t[row - 1]} s")
    return t


def _rmse(err: np.ndarray, convention: Convention) -> float:
    """The array functions' aggregate: RoNIN averages squared coordinates, the others squared distances."""
    return per_axis_rms(err) if convention is Convention.RONIN else euclidean_rmse(err)


def _relative_error(
    est: np.ndarray, gt: np.ndarray, t_s: np.ndarray, window_s: float, convention: Convention
) -> float:
    return relative_error(est, gt, t_s, window_s, lambda err: _rmse(err, convention))


def _drift_ratio(est: np.ndarray, gt: np.ndarray) -> float:
    return drift_ratio(est, gt)


def _common_samples(est: Trajectory, gt: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t_s, est positions, gt positions) at the ground-truth timestamps both trajectories cover."""
    if len(est) < 2 or len(gt) < 2:
        raise ValueError(
            f"trajectory metrics need at least 2 samples; the estimate has {len(est)}, "
            f"the ground truth {len(gt)}"
        )
    t_gt = _check_times(gt.t_s, len(gt), "ground-truth t_s")
    if len(est) == len(gt) and np.allclose(est.t_s, t_gt, rtol=0.0, atol=_SAME_TIME_TOL_S):
        return t_gt, est.p_world_m, gt.p_world_m
    t_est = _check_times(est.t_s, len(est), "estimate t_s")
    start_s = max(t_est[0], t_gt[0])
    stop_s = min(t_est[-1], t_gt[-1])
    inside = (t_gt >= start_s - _SAME_TIME_TOL_S) & (t_gt <= stop_s + _SAME_TIME_TOL_S)
    if start_s >= stop_s or inside.sum() < 2:
        raise ValueError(
            f"estimate ({t_est[0]:.3f}..{t_est[-1]:.3f} s) and ground truth "
            f"({t_gt[0]:.3f}..{t_gt[-1]:.3f} s) do not overlap in at least 2 ground-truth samples"
        )
    t_s = t_gt[inside]
    # Clip to the estimate's span so float noise at the ends never extrapolates.
    t_query = np.clip(t_s, t_est[0], t_est[-1])
    est_m = np.column_stack([np.interp(t_query, t_est, est.p_world_m[:, j]) for j in range(3)])
    return t_s, est_m, gt.p_world_m[inside]
