"""What a model reads its speed from: change one cue of real walking windows, watch the speed.

``speed_cue_probe(predict, prepared_sequences, window)`` takes world-frame windows of walks (ground
truth needed: it sets the direction of travel and keeps only windows that move) and reports, per
probe, how much the mean predicted horizontal speed changes (``100 * (mean new / mean original - 1)``,
the same windows):

- amplitude probes: the zero-mean part of one acceleration component (its window mean, gravity on
  the vertical, stays) scaled by each factor (``ftin.train.augment.scale_acc_component``):
  ``vertical`` (the bounce), ``cross_track`` (the side-to-side swing, horizontal and perpendicular to
  the window's true velocity) and ``along_track``; the gyro is untouched;
- rhythm probe (``cadence``): the window is resampled from a span of ``factor x window`` samples of
  the same recording starting at the same sample, so the step frequency changes by ``factor`` while
  the amplitudes (acc and gyro) stay. A model that reads speed from the rhythm follows the cadence
  (stride length fixed: speed x factor); one that reads the bounce's strength does not move.
  Windows are kept only where ``max(cadence factors) x window`` samples exist.

``window_predictor(loaded)`` gives ``predict`` for a checkpoint of a window model (its input
normalisation, the mean over a window's parts), in batches under ``torch.inference_mode``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from ftin.checkpoint import LoadedModel
from ftin.data.prepare import PreparedSequence
from ftin.data.windows import velocity_targets, warp_windows, window_starts
from ftin.train.augment import scale_acc_component

COMPONENTS = ("vertical", "cross_track", "along_track")
AMPLITUDE_FACTORS = (0.0, 0.5, 1.5)
CADENCE_FACTORS = (0.8, 1.25)
MIN_SPEED_M_S = 0.3  # windows slower than this have no reliable direction of travel

Predict = Callable[[np.ndarray], np.ndarray]  # (B, 6, L) world-frame windows -> (B, D) velocities


@dataclass(frozen=True)
class ProbeRow:
    probe: str  # "vertical", "cross_track", "along_track" or "cadence"
    factor: float
    speed_change_pct: float  # mean predicted speed, changed windows vs original, in %
    windows: int


def window_predictor(loaded: LoadedModel, batch: int = 256) -> Predict:
    """``predict`` for a window model's checkpoint (streaming models have no windows: ValueError)."""
    if loaded.model.streams:
        raise ValueError(f"{loaded.name}: a streaming model has no windows to probe")

    def predict(x: np.ndarray) -> np.ndarray:
        out = []
        with torch.inference_mode():
            for i in range(0, len(x), batch):
                xb = loaded.normalization.apply(torch.from_numpy(np.ascontiguousarray(x[i : i + batch])))
                out.append(loaded.model.forward_parts(xb).velocity.mean(dim=1).numpy())
        return np.concatenate(out)

    return predict


def direction(component: str, along: np.ndarray) -> np.ndarray:
    """``(M, 3)`` unit vectors of a component, given the horizontal unit direction of travel ``(M, 2)``."""
    m = len(along)
    if component == "vertical":
        return np.tile([0.0, 0.0, 1.0], (m, 1))
    if component == "along_track":
        return np.column_stack([along, np.zeros(m)])
    if component == "cross_track":
        return np.column_stack([-along[:, 1], along[:, 0], np.zeros(m)])
    raise ValueError(f"unknown component {component!r}; known: {', '.join(COMPONENTS)}")


def time_warp(imu: np.ndarray, starts: np.ndarray, window: int, factor: float) -> np.ndarray:
    """``(M, 6, window)`` windows resampled from ``factor x window`` samples of ``imu (N, 6)`` from each
    start (``ftin.data.windows.warp_windows``; amplitudes unchanged). ``factor`` 1 gives the plain windows."""
    try:
        return warp_windows(imu, starts, window, np.full(len(starts), float(factor)))
    except ValueError as exc:
        raise ValueError(f"time warp x{factor}: {exc}") from None


def probe_windows(
    prepared: PreparedSequence, window: int, stride: int, reach: float = max(CADENCE_FACTORS)
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(starts, x (M, 6, L), along (M, 2))`` of the windows that move at ``MIN_SPEED_M_S`` or more and
    whose ``reach x window`` samples exist."""
    seq = prepared.seq
    if seq.gt is None:
        raise ValueError(f"{seq.name}: the speed-cue probe needs ground truth (direction of travel)")
    imu = prepared.imu_world
    span = int(np.ceil(reach * window))
    starts = window_starts(len(seq) - (span - window), window, stride)
    v = velocity_targets(seq.t_s, seq.gt.p_world_m, starts, window, 2).astype(np.float64)
    speed = np.linalg.norm(v, axis=1)
    keep = speed >= MIN_SPEED_M_S
    starts, v, speed = starts[keep], v[keep], speed[keep]
    return starts, time_warp(imu, starts, window, 1.0), v / speed[:, None]


def speed_cue_probe(
    predict: Predict,
    sequences: Sequence[PreparedSequence],
    window: int,
    stride: int,
    amplitude_factors: Sequence[float] = AMPLITUDE_FACTORS,
    cadence_factors: Sequence[float] = CADENCE_FACTORS,
) -> list[ProbeRow]:
    """One row per component and factor, then per cadence factor, over every sequence's windows."""
    reach = max([1.0, *cadence_factors])
    parts = [probe_windows(p, window, stride, reach) for p in sequences]
    if not any(len(s) for s, _, _ in parts):
        raise ValueError("no moving windows to probe: the sequences are too short or never move")
    x = np.concatenate([xw for _, xw, _ in parts])
    along = np.concatenate([a for _, _, a in parts])

    def speed(windows: np.ndarray) -> float:
        return float(np.linalg.norm(predict(windows)[:, :2], axis=1).mean())

    base = speed(x)
    rows = []
    for component in COMPONENTS:
        u = direction(component, along)
        for factor in amplitude_factors:
            changed = speed(scale_acc_component(x, u, factor))
            rows.append(ProbeRow(component, float(factor), 100.0 * (changed / base - 1.0), len(x)))
    for factor in cadence_factors:
        pairs = zip(sequences, parts, strict=True)
        warped = np.concatenate(
            [time_warp(p.imu_world, s, window, factor) for p, (s, _, _) in pairs if len(s)]
        )
        rows.append(ProbeRow("cadence", float(factor), 100.0 * (speed(warped) / base - 1.0), len(x)))
    return rows
