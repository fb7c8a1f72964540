"""Preprocessing of ``ImuSequence``: resampling and orientation estimation.

Every function returns a new sequence (the types are immutable) with ``meta`` copied, never
shared, and appends to ``meta["warnings"]`` whatever it assumed, to ``meta["notes"]`` what it did
(``ftin.data.messages``).
"""

from __future__ import annotations

from enum import Enum
from typing import Any

import numpy as np
from ahrs.filters import Madgwick, Mahony
from scipy.signal import butter, sosfiltfilt
from scipy.spatial.transform import Rotation
from vqf import offlineVQF

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.messages import Note, with_messages
from ftin.data.types import ImuSequence, Trajectory

# Anti-alias low-pass cut-off as a fraction of the new Nyquist frequency (leaves a transition band).
_ANTIALIAS_FRACTION_OF_NYQUIST = 0.8
_ANTIALIAS_ORDER = 4


def _meta_with_warning(meta: dict[str, Any], *warnings: str, **updates: Any) -> dict[str, Any]:
    """A copy of ``meta`` with ``updates`` applied and ``warnings`` appended (input untouched); a
    ``Note`` among them goes to ``meta["notes"]`` (``ftin.data.messages``)."""
    return with_messages(meta, warnings, **updates)


def _require_increasing_time(seq: ImuSequence) -> None:
    steps = np.diff(seq.t_s)
    bad = np.flatnonzero(~(steps > 0))
    if len(bad):
        k = int(bad[0])
        raise DataFormatError(
            f"sequence {seq.name!r}: t_s must be strictly increasing, but row {k + 1} "
            f"({seq.t_s[k + 1]!r} s) does not come after row {k} ({seq.t_s[k]!r} s)"
        )


def _quat_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products ``a b`` of wxyz quaternions given as ``(4, N)`` rows (w, x, y, z)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def _unit_rows(q: np.ndarray) -> np.ndarray:
    """``(4, N)`` unit quaternions of the ``(N, 4)`` ``q``."""
    q = np.ascontiguousarray(q.T)
    return q / np.sqrt(np.einsum("ij,ij->j", q, q))


def _slerp(t_s: np.ndarray, q_wxyz: np.ndarray, t_new_s: np.ndarray) -> np.ndarray:
    """Orientations at ``t_new_s`` (inside ``t_s``'s span), interpolated along the shortest arc
    between the samples around each, as ``scipy.spatial.transform.Slerp`` does (the same rotations to
    rounding), in plain numpy over the intervals used only: scipy's took seconds for an hour at
    200 Hz, this a fraction of one. Signs made continuous (``make_continuous``)."""
    t_new = np.asarray(t_new_s, dtype=np.float64)
    if t_new.size and (t_new[0] < t_s[0] or t_new[-1] > t_s[-1]):
        raise ValueError(f"interpolation times must be within [{t_s[0]}, {t_s[-1]}]")
    i = np.clip(np.searchsorted(t_s, t_new) - 1, 0, len(t_s) - 2)  # the interval [t_i, t_i+1] of each
    alpha = (t_new - t_s[i]) / (t_s[i + 1] - t_s[i])
    q = np.asarray(q_wxyz, dtype=np.float64)
    start, end = _unit_rows(q[i]), _unit_rows(q[i + 1])
    rel = _quat_product(start * np.array([[1.0], [-1.0], [-1.0], [-1.0]]), end)  # the interval's turn
    rel *= np.where(rel[0] < 0, -1.0, 1.0)  # the shortest arc (angle <= pi)
    sin_half = np.sqrt(rel[1] * rel[1] + rel[2] * rel[2] + rel[3] * rel[3])
    part = alpha * np.arctan2(sin_half, rel[0])  # half the angle turned by t_new
    tiny = sin_half < 1e-12  # no turn: sin(part) / sin_half -> alpha
    scale = np.where(tiny, alpha, np.sin(part) / np.where(tiny, 1.0, sin_half))
    turned = np.concatenate([np.cos(part)[None], rel[1:] * scale])
    return frames.make_continuous(np.ascontiguousarray(_quat_product(start, turned).T))


def _interp_columns(t_s: np.ndarray, values: np.ndarray, t_new_s: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(t_new_s, t_s, values[:, i]) for i in range(values.shape[1])])


def resample(seq: ImuSequence, rate_hz: float, antialias: bool = True) -> ImuSequence:
    """The sequence on a uniform grid ``t_s[0] + k / rate_hz`` inside the original time span.

    Vectors (gyro, specific force, magnetometer, ground-truth positions) are interpolated linearly,
    orientations by Slerp; a ground-truth sample is tracked when the samples around it both were.
    Decision: when the new rate is lower than the old one and ``antialias`` is set, gyro and
    specific force first pass a zero-phase Butterworth low-pass (order 4, cut-off at 0.8 x the new
    Nyquist frequency) so that vibration above the new Nyquist frequency does not fold into the band
    (EuRoC's 200 Hz drone IMU resampled to 100 Hz, say). Ground truth is smooth and is not filtered.
    """
    if not np.isfinite(rate_hz) or rate_hz <= 0:
        raise ValueError(f"rate_hz must be a positive number, got {rate_hz!r}")
    if len(seq) < 2:
        raise DataFormatError(f"sequence {seq.name!r} has {len(seq)} samples: resampling needs at least 2")
    _require_increasing_time(seq)
    t_old = seq.t_s
    n_new = int(np.floor((t_old[-1] - t_old[0]) * rate_hz + 1e-9)) + 1
    t_new = t_old[0] + np.arange(n_new) / rate_hz

    gyro, acc = seq.gyro_rad_s, seq.acc_m_s2
    old_rate_hz = seq.rate_hz
    warnings: list[str] = []
    if antialias and rate_hz < old_rate_hz:
        sos = butter(
            _ANTIALIAS_ORDER,
            _ANTIALIAS_FRACTION_OF_NYQUIST * rate_hz / 2.0,
            btype="low",
            fs=old_rate_hz,
            output="sos",
        )
        pad = 3 * (2 * len(sos) + 1)  # sosfiltfilt's default padding must fit in the signal
        if len(seq) > pad:
            gyro = sosfiltfilt(sos, gyro, axis=0)
            acc = sosfiltfilt(sos, acc, axis=0)
        else:
            warnings.append(f"resample: {len(seq)} samples are too few to low-pass before downsampling")

    q = None if seq.q_world_device_wxyz is None else _slerp(t_old, seq.q_world_device_wxyz, t_new)
    gt = None
    if seq.gt is not None:
        gt_q = None if seq.gt.q_world_body_wxyz is None else _slerp(t_old, seq.gt.q_world_body_wxyz, t_new)
        tracked = None
        if seq.gt.tracked is not None:  # a new sample is measured when both old ones around it are
            tracked = np.interp(t_new, t_old, seq.gt.tracked.astype(np.float64)) > 1.0 - 1e-9
        gt = Trajectory(t_new, _interp_columns(t_old, seq.gt.p_world_m, t_new), gt_q, tracked)
    mag = None if seq.mag_uT is None else _interp_columns(t_old, seq.mag_uT, t_new)
    return ImuSequence(
        seq.name,
        t_new,
        _interp_columns(t_old, gyro, t_new),
        _interp_columns(t_old, acc, t_new),
        q,
        gt,
        _meta_with_warning(seq.meta, *warnings, rate_hz=float(rate_hz)),
        mag,
        seq.waypoints,  # marks in time, not samples: unchanged by the grid
    )


class AhrsMethod(str, Enum):
    """Attitude filters for recordings without orientation.

    ``VQF`` (the default): Laidig & Seel's VQF (Information Fusion 2023) in its offline batch mode
    (``vqf.offlineVQF``, C++ core): forward-backward filtering with gyroscope bias estimation and rest
    detection; 9-D (magnetometer-referenced heading) when the recording carries a magnetometer
    (``ImuSequence.mag_uT``), else 6-D. ``MADGWICK`` / ``MAHONY``: the ``ahrs`` package's
    filters, one Python call per sample (kept for comparison: ``experiments/orientation_quality.py``).
    """

    VQF = "vqf"
    MADGWICK = "madgwick"
    MAHONY = "mahony"


def _initial_orientation_from_gravity(seq: ImuSequence, init_s: float) -> np.ndarray:
    """Level start: the smallest rotation taking the first sample's "up" to world +z.

    "Up" is the mean specific force over the first ``init_s`` seconds, each sample first rotated
    back into the first sample's device frame with the integrated gyro, so that a device that is
    already turning at the start does not smear the estimate.
    """
    n_first = max(1, int(np.searchsorted(seq.t_s, seq.t_s[0] + init_s, side="right")))
    steps = Rotation.from_rotvec(seq.gyro_rad_s[1:n_first] * np.diff(seq.t_s[:n_first])[:, None])
    R_first_k = [Rotation.identity()]
    for step in steps:
        R_first_k.append(R_first_k[-1] * step)
    mean_acc = Rotation.concatenate(R_first_k).apply(seq.acc_m_s2[:n_first]).mean(axis=0)
    norm = float(np.linalg.norm(mean_acc))
    if not np.isfinite(norm) or norm < 1e-6:
        raise DataFormatError(
            f"sequence {seq.name!r}: the specific force of the first {init_s} s averages to "
            f"{mean_acc.tolist()} m/s^2, so gravity (and the initial tilt) cannot be found"
        )
    rotation, _ = Rotation.align_vectors([[0.0, 0.0, 1.0]], [mean_acc / norm])
    return frames.wxyz_from_rotation(rotation)


def estimate_orientation(
    seq: ImuSequence,
    method: AhrsMethod | str = AhrsMethod.VQF,
    init_s: float = 0.5,
    align_window_s: float = 2.0,
    *,
    use_magnetometer: bool = True,
    **filter_options: float,
) -> ImuSequence:
    """Estimate ``q_world_device_wxyz`` with an attitude filter (``AhrsMethod``, VQF by default).

    All filters return world-from-device quaternions whose world +z is the direction of the measured
    specific force at rest (checked by tests on a synthetic rotating device), i.e. exactly our
    ``q_world_device`` with z up. VQF runs on the whole recording at once (its sample time is the
    median interval: readers guarantee a near-uniform clock); with a magnetometer
    (``seq.mag_uT``, and ``use_magnetometer``) it runs in 9-D mode and the heading is
    referenced to magnetic north, else in 6-D mode and the heading is arbitrary and drifts slowly;
    ``meta["orientation_filter"]`` and a warning name the mode that ran. ``filter_options`` go to the
    filter (VQF: its ``params`` keys, e.g. ``tauAcc``; Madgwick: ``gain``; Mahony: ``k_P``, ``k_I``).
    Madgwick and Mahony start level from the gyro-compensated mean specific force of the first
    ``init_s`` seconds (yaw 0) and use each sample's real time step.

    Ground truth, if any, must stay in the sequence's world frame: when the sequence already had an
    orientation, the gt is turned by the yaw between the new and the old world frame over the first
    ``align_window_s`` seconds; without one there is nothing to align against: a note says so, and
    ``meta["gt_frame"] = "unknown"`` makes scoring align the start (``ftin.evaluate.score`` warns where
    it is asked not to).
    """
    try:
        method = AhrsMethod(method)
    except ValueError:
        choices = ", ".join(m.value for m in AhrsMethod)
        raise ValueError(f"method must be one of {choices}; got {method!r}") from None
    if len(seq) < 2:
        raise DataFormatError(f"sequence {seq.name!r} has {len(seq)} samples: AHRS needs at least 2")
    _require_increasing_time(seq)
    if method is AhrsMethod.VQF:
        _initial_orientation_from_gravity(seq, init_s)  # refuses a recording without gravity, by name
        q, mode = _vqf(seq, use_magnetometer, filter_options)
        if mode == "9d":
            what = (
                "the VQF filter (9-D: gyroscope, accelerometer and magnetometer; heading from magnetic north)"
            )
        else:
            what = "the VQF filter (6-D, without magnetometer): heading is arbitrary and drifts"
        filter_name = f"vqf-{mode}"
    else:
        q = _ahrs_loop(seq, method, init_s, filter_options)
        what = f"the {method.value} AHRS filter without magnetometer: heading is arbitrary and drifts"
        filter_name = method.value
    q = frames.make_continuous(q)

    warnings: list[str] = [Note(f"orientation estimated by {what}")]  # once: prepare says no more
    gt = seq.gt
    if gt is not None and seq.q_world_device_wxyz is not None:
        yaw, _ = frames.yaw_offset_rad(seq.t_s, q, seq.q_world_device_wxyz, align_window_s)
        gt = frames.rotate_trajectory_about_z(gt, yaw)
        warnings.append(
            Note(
                f"ground truth turned by {np.degrees(yaw):.1f} deg about z to the estimated world frame "
                f"(aligned over the first {align_window_s} s)"
            )
        )
    elif gt is not None:  # information: scoring aligns the start (``gt_frame`` "unknown"); it warns if not
        warnings.append(
            Note(
                "the ground truth keeps its own heading (the recording had no orientation to relate it "
                "to): scoring aligns it at the start"
            )
        )
    updates: dict[str, Any] = {"orientation_source": "estimated", "orientation_filter": filter_name}
    if gt is not None and seq.q_world_device_wxyz is None:
        updates["gt_frame"] = "unknown"  # nothing related the two world frames (ftin.metrics.alignment_modes)
    meta = _meta_with_warning(seq.meta, *warnings, **updates)
    return seq.with_(q_world_device_wxyz=q, gt=gt, meta=meta)


def _vqf(seq: ImuSequence, use_magnetometer: bool, options: dict[str, float]) -> tuple[np.ndarray, str]:
    """``(q_world_device_wxyz, "6d" | "9d")`` from ``vqf.offlineVQF`` (scalar-first, z up)."""
    mag = seq.mag_uT if use_magnetometer else None
    if mag is not None and not np.isfinite(mag).all():
        mag = None  # a broken magnetometer must not break the attitude: 6-D instead
    gyr = np.ascontiguousarray(seq.gyro_rad_s, dtype=np.float64)
    acc = np.ascontiguousarray(seq.acc_m_s2, dtype=np.float64)
    sample_time_s = float(np.median(np.diff(seq.t_s)))
    out = offlineVQF(
        gyr, acc, None if mag is None else np.ascontiguousarray(mag), sample_time_s, dict(options) or None
    )
    if mag is not None:
        return np.asarray(out["quat9D"], dtype=np.float64), "9d"
    return np.asarray(out["quat6D"], dtype=np.float64), "6d"


def _ahrs_loop(seq: ImuSequence, method: AhrsMethod, init_s: float, options: dict[str, float]) -> np.ndarray:
    """The ``ahrs`` package's Madgwick or Mahony filter, one call per sample."""
    rate_hz = seq.rate_hz
    if method is AhrsMethod.MADGWICK:
        ahrs_filter = Madgwick(frequency=rate_hz, **options)
    else:
        ahrs_filter = Mahony(frequency=rate_hz, **options)
    q = np.empty((len(seq), 4))
    q[0] = _initial_orientation_from_gravity(seq, init_s)
    dt_s = np.diff(seq.t_s)
    gyro, acc = seq.gyro_rad_s, seq.acc_m_s2
    for k in range(1, len(seq)):
        # ahrs integrates gyr[k] over the step that ends at sample k.
        q[k] = ahrs_filter.updateIMU(q[k - 1], gyr=gyro[k], acc=acc[k], dt=float(dt_s[k - 1]))
    return q


def ensure_orientation(seq: ImuSequence, method: AhrsMethod | str = AhrsMethod.VQF) -> ImuSequence:
    """``seq`` itself when it has an orientation, else :func:`estimate_orientation`."""
    if seq.q_world_device_wxyz is not None:
        return seq
    return estimate_orientation(seq, method)
