"""A recording with held holes (``ftin.data.gaps``: seconds with no samples, interpolated on the grid)
through the filter: one filter per stretch between holes, never one across a hole.

The IMU inside a hole is invented (linear interpolation of its edges): integrated, it moves the
filter's tilt, velocity and biases by whatever the interpolation says (a RIDI bag walk's 4.4 s hole
turned the tilt 62 deg and the accelerometer bias to 5 m/s^2, ATE 4.5 -> 19 m). So, as inference holds
its position across a hole (``ftin.infer.outside_holes``), each stretch gets its own filter, started
from the orientation filter's attitude at its first sample and the position the last stretch ended at;
across a hole (and over a stretch shorter than one window) the position is held, the orientation is
the orientation filter's, the velocity zero, the biases and covariances the last stretch's. The
position covariance carries on: each later stretch adds its own to the last one's end.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ftin.data.gaps import holes_of
from ftin.data.types import ImuSequence
from ftin.data.windows import world_imu
from ftin.filter.session import FilterRun

Runner = Callable[[ImuSequence, np.ndarray, np.ndarray | None, int], FilterRun]


def stretches(t_s: np.ndarray, holes_s: np.ndarray) -> list[tuple[int, int]]:
    """``[start, stop)`` sample ranges between the holes (a hole's edge samples are real and belong to
    the stretches on either side)."""
    inside = np.zeros(len(t_s), dtype=bool)
    for a, b in holes_s:
        inside |= (t_s > a) & (t_s < b)
    edges = np.flatnonzero(np.diff(np.concatenate([[1], inside.astype(np.int8), [1]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def run_around_holes(
    seq: ImuSequence,
    window: int,
    start_position_m: np.ndarray,
    heading_ref_rad: np.ndarray | None,
    run_stretch: Runner,
) -> FilterRun:
    """One ``run_stretch(piece, start_position, heading_ref, offset)`` per stretch of ``seq`` of at
    least one window and its end (module docstring), joined into one run over every sample."""
    n = len(seq)
    position = np.asarray(start_position_m, dtype=np.float64).copy()
    pos_cov = np.zeros((2, 2))
    parts: list[FilterRun] = []
    last = {"bg": np.zeros(3), "ba": np.zeros(3), "tilt_cov": np.zeros((2, 2)), "k": 1.0}
    held_from = 0  # first sample not covered by a stretch's run yet
    for a, b in stretches(seq.t_s, holes_of(seq)):
        if b - a < window + 1:
            continue
        if a > held_from:
            parts.append(_held(seq, held_from, a, position, pos_cov, last))
        ref = None if heading_ref_rad is None else heading_ref_rad[a:b]
        run = run_stretch(seq.slice(a, b), position, ref, a)
        run.position_cov_xy[...] += pos_cov  # uncertainty carries across the hole
        parts.append(run)
        position = run.p_world_m[-1].copy()
        pos_cov = run.position_cov_xy[-1].copy()
        last = {
            "bg": run.gyro_bias_rad_s[-1],
            "ba": run.acc_bias_m_s2[-1],
            "tilt_cov": run.tilt_cov[-1],
            "k": float(run.speed_scale[-1]),
        }
        held_from = b
    if not parts:
        raise ValueError(
            f"{seq.name!r}: no stretch between its holes is long enough for the filter "
            f"(a window needs {window + 1} samples)"
        )
    if held_from < n:
        parts.append(_held(seq, held_from, n, position, pos_cov, last))
    return _joined(parts)


def _held(
    seq: ImuSequence, a: int, b: int, position: np.ndarray, pos_cov: np.ndarray, last: dict
) -> FilterRun:
    """Samples ``[a, b)`` with the position held and no update (module docstring)."""
    k = b - a
    piece = seq.slice(a, b)
    return FilterRun(
        t_s=piece.t_s.copy(),
        p_world_m=np.tile(position, (k, 1)),
        velocity_state_m_s=np.zeros((k, 3)),
        q_world_device_wxyz=np.asarray(piece.q_world_device_wxyz, dtype=np.float64).copy(),
        gyro_bias_rad_s=np.tile(last["bg"], (k, 1)),
        acc_bias_m_s2=np.tile(last["ba"], (k, 1)),
        position_cov_xy=np.tile(pos_cov, (k, 1, 1)),
        tilt_cov=np.tile(last["tilt_cov"], (k, 1, 1)),
        imu_world=world_imu(piece),
        update_span=np.zeros((0, 2), dtype=np.int64),
        velocity_m_s=np.zeros((0, 3)),
        nis=np.zeros(0),
        applied=np.zeros(0, dtype=bool),
        covariance=np.zeros((0, 15, 15)),  # no update here; _joined keeps the runs' own
        speed_scale=np.full(k, last["k"]),
    )


def _joined(parts: list[FilterRun]) -> FilterRun:
    """The parts one after another; each part's update spans moved to the whole run's samples."""
    offsets = np.cumsum([0, *(len(p.t_s) for p in parts[:-1])])
    dim = next((p.velocity_m_s.shape[1] for p in parts if len(p.velocity_m_s)), 3)
    return FilterRun(
        t_s=np.concatenate([p.t_s for p in parts]),
        p_world_m=np.concatenate([p.p_world_m for p in parts]),
        velocity_state_m_s=np.concatenate([p.velocity_state_m_s for p in parts]),
        q_world_device_wxyz=np.concatenate([p.q_world_device_wxyz for p in parts]),
        gyro_bias_rad_s=np.concatenate([p.gyro_bias_rad_s for p in parts]),
        acc_bias_m_s2=np.concatenate([p.acc_bias_m_s2 for p in parts]),
        position_cov_xy=np.concatenate([p.position_cov_xy for p in parts]),
        tilt_cov=np.concatenate([p.tilt_cov for p in parts]),
        imu_world=np.concatenate([np.asarray(p.imu_world, dtype=np.float32) for p in parts]),
        update_span=np.concatenate([p.update_span + o for p, o in zip(parts, offsets, strict=True)]),
        velocity_m_s=np.concatenate([p.velocity_m_s.reshape(-1, dim) for p in parts]),
        nis=np.concatenate([p.nis for p in parts]),
        applied=np.concatenate([p.applied for p in parts]),
        covariance=np.concatenate([p.covariance for p in parts if len(p.covariance)]),
        speed_scale=np.concatenate([p.speed_scale for p in parts]),
    )
