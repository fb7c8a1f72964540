"""Inference: one IMU recording + one checkpoint -> per-window velocities -> a trajectory.

``predict_trajectory`` is the one function the CLI (``ftin predict``), the evaluation and the app
call. Steps and decisions:

1. Orientation: the sequence's own (device attitude, or ground truth as a reader chose); when it
   has none, an AHRS filter estimates it (``ensure_orientation``) and a warning says so.
2. Rate: unless the input already lies on a uniform grid at the checkpoint's ``imu_rate_hz``, it is
   resampled to it (ground truth too), because the window length means a duration only at that
   rate. The output trajectory is sampled at the (resampled) IMU timestamps.
3. Windows of ``window`` samples every ``stride`` samples (the checkpoint's stride unless given),
   exactly as in training (``ftin.data.windows``), streamed through the model in batches under
   ``torch.inference_mode``: only one batch of windows exists at a time (each batch is copied out of
   a strided view of the ``(N, 6)`` world-frame IMU), so window memory does not grow with the
   recording; feature taps are kept only when asked for. What does grow is linear in the number of
   samples and small per sample: the resampled, rotated IMU, the velocities and the trajectory
   (``scripts/bench_memory.py`` measures the peak RSS of a 1-hour 200 Hz recording).
4. Integration: a window's velocity is the mean velocity over its span ``[t[s], t[s + L]]``, so each
   sample interval ``[t[i], t[i+1]]`` gets the average velocity of the windows covering it (with
   stride = window this integrates each window's displacement exactly). Intervals after the last
   window (fewer than ``stride`` samples) keep the last window's velocity. Positions start at the
   ground-truth start position when there is ground truth, else at the origin; with a 2-D model
   z stays at the start height, a 3-D model integrates z too.
5. Frames: with ground truth the estimate lives in the ground-truth world frame (readers align it
   with the device world frame at the start, design §2) and metrics are computed; without it, the
   estimate is in the device's own world frame (gravity-aligned, arbitrary yaw).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.windows import window_starts, window_view, world_imu
from ftin.metrics import Convention, TrajectoryMetrics, evaluate_trajectory
from ftin.train.checkpoint import LoadedModel

FRAME_GROUND_TRUTH = "ground_truth"
FRAME_DEVICE_WORLD = "device_world"
_RATE_TOLERANCE = 1e-3  # relative deviation of the sample interval still called "on the grid"


@dataclass
class Prediction:
    trajectory: Trajectory
    window_t_s: np.ndarray  # (M,) middle of each window's span [t[s], t[s + L]]
    velocity_m_s: np.ndarray  # (M, D) world-frame velocity per window
    orientation_source: str  # "device", "ground_truth" or "estimated"
    frame: str  # "ground_truth" or "device_world"
    warnings: list[str]
    metrics: TrajectoryMetrics | None
    features: dict | None  # name -> (M, ...) float32 feature taps, when asked


def predict_trajectory(
    loaded: LoadedModel,
    seq: ImuSequence,
    *,
    stride: int | None = None,
    batch_size: int = 1024,
    progress: Callable[[int, int], None] | None = None,
    return_features: bool = False,
) -> Prediction:
    """Run ``loaded`` over ``seq`` and integrate a trajectory; see the module docstring."""
    prediction, _ = predict_prepared(
        loaded,
        seq,
        stride=stride,
        batch_size=batch_size,
        progress=progress,
        return_features=return_features,
    )
    return prediction


def predict_prepared(
    loaded: LoadedModel,
    seq: ImuSequence,
    *,
    stride: int | None = None,
    batch_size: int = 1024,
    progress: Callable[[int, int], None] | None = None,
    return_features: bool = False,
    convention: Convention = Convention.RONIN,
    rte_window_s: float = 60.0,
) -> tuple[Prediction, ImuSequence]:
    """``predict_trajectory`` plus the oriented, resampled sequence it ran on (for evaluation)."""
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    stride = loaded.stride if stride is None else stride
    if stride < 1:
        raise ValueError(f"stride must be >= 1 sample, got {stride}")
    prepared, notes = prepare_for_checkpoint(loaded, seq)
    window = loaded.window
    if len(prepared) < window + 1:
        raise DataFormatError(
            f"sequence {seq.name!r} is too short: {len(prepared)} samples at {loaded.imu_rate_hz:g} Hz, "
            f"checkpoint {loaded.name!r} needs at least {window + 1} (a {window}-sample window and its end)"
        )
    imu = world_imu(prepared)  # (N, 6) float32
    starts = window_starts(len(prepared), window, stride)
    velocity, features = _run_windows(loaded, imu, starts, batch_size, progress, return_features)
    t_s = prepared.t_s
    start_m = prepared.gt.p_world_m[0] if prepared.gt is not None else np.zeros(3)
    p_world_m = integrate_windows(t_s, starts, window, velocity, start_m)
    trajectory = Trajectory(t_s.copy(), p_world_m, prepared.q_world_device_wxyz)

    warnings = [*prepared.meta.get("warnings", []), *notes]
    metrics = None
    if prepared.gt is not None:
        try:
            metrics = evaluate_trajectory(trajectory, prepared.gt, convention, rte_window_s)
        except ValueError as exc:  # e.g. a ground truth that never moves has no PDE
            warnings.append(f"metrics unavailable: {exc}")
    orientation_source = str(prepared.meta.get("orientation_source", "device"))
    prediction = Prediction(
        trajectory=trajectory,
        window_t_s=0.5 * (t_s[starts] + t_s[starts + window]),
        velocity_m_s=velocity,
        orientation_source=orientation_source,
        frame=FRAME_GROUND_TRUTH if prepared.gt is not None else FRAME_DEVICE_WORLD,
        warnings=warnings,
        metrics=metrics,
        features=features,
    )
    return prediction, prepared


def prepare_for_checkpoint(loaded: LoadedModel, seq: ImuSequence) -> tuple[ImuSequence, list[str]]:
    """The sequence with an orientation, on a uniform grid at the checkpoint's rate; plus notes."""
    from ftin.data.preprocess import ensure_orientation, resample

    notes: list[str] = []
    prepared = ensure_orientation(seq)
    if seq.q_world_device_wxyz is None:
        notes.append(
            f"{seq.name}: the input has no device orientation; it was estimated with an AHRS filter, "
            "so the heading may drift"
        )
    rate_hz = loaded.imu_rate_hz
    steps = np.diff(prepared.t_s)
    on_grid = len(steps) > 0 and np.allclose(steps, 1.0 / rate_hz, rtol=_RATE_TOLERANCE, atol=0.0)
    if not on_grid:
        if len(prepared) > 1 and abs(prepared.rate_hz - rate_hz) > 0.01 * rate_hz:
            notes.append(
                f"{seq.name}: resampled from {prepared.rate_hz:.4g} Hz to the checkpoint's {rate_hz:g} Hz"
            )
        prepared = resample(prepared, rate_hz)
    return prepared, notes


def integrate_windows(
    t_s: np.ndarray, starts: np.ndarray, window: int, velocity_m_s: np.ndarray, start_m: np.ndarray
) -> np.ndarray:
    """``(N, 3)`` positions from per-window mean velocities (module docstring, step 4)."""
    n, d = len(t_s), velocity_m_s.shape[1]
    # Difference arrays: +v where a window's span begins, -v where it ends; the running sum over
    # intervals is then the sum of the velocities of all windows covering each interval.
    delta = np.zeros((n, d))
    delta[starts] += velocity_m_s
    delta[starts + window] -= velocity_m_s
    count_delta = np.zeros(n)
    count_delta[starts] += 1.0
    count_delta[starts + window] -= 1.0
    v_sum = np.cumsum(delta, axis=0)[: n - 1]  # (N - 1, D) per interval
    count = np.rint(np.cumsum(count_delta)[: n - 1])
    v_interval = np.empty((n - 1, d))
    covered = count > 0
    v_interval[covered] = v_sum[covered] / count[covered, None]
    v_interval[~covered] = velocity_m_s[-1]  # only the tail after the last window is uncovered
    p = np.tile(np.asarray(start_m, dtype=np.float64), (n, 1))
    steps = v_interval * np.diff(t_s)[:, None]  # (N - 1, D) displacement per interval
    p[1:, :d] += np.cumsum(steps, axis=0)
    return p


def _run_windows(
    loaded: LoadedModel,
    imu: np.ndarray,
    starts: np.ndarray,
    batch_size: int,
    progress: Callable[[int, int], None] | None,
    return_features: bool,
) -> tuple[np.ndarray, dict | None]:
    """Per-window velocities ``(M, D)`` (float64) and, when asked, the concatenated feature taps."""
    model = loaded.model
    device = next(model.parameters()).device
    view = window_view(imu, loaded.window)  # (N - L + 1, 6, L), a view: no copy
    total = len(starts)
    velocity = np.empty((total, loaded.out_dim))
    taps: dict[str, list[np.ndarray]] | None = {} if return_features else None
    model.eval()
    with torch.inference_mode():
        for first in range(0, total, batch_size):
            batch_starts = starts[first : first + batch_size]
            x = torch.from_numpy(np.ascontiguousarray(view[batch_starts])).to(device)  # (B, 6, L)
            features: dict | None = {} if return_features else None
            output = model(loaded.normalization.apply(x), features=features)
            velocity[first : first + len(batch_starts)] = output.velocity.double().cpu().numpy()
            if taps is not None:
                if output.log_std is not None:
                    features["log_std"] = output.log_std
                for name, value in features.items():
                    taps.setdefault(name, []).append(value.detach().float().cpu().numpy())
            if progress is not None:
                progress(first + len(batch_starts), total)
    joined = None if taps is None else {name: np.concatenate(parts, axis=0) for name, parts in taps.items()}
    return velocity, joined
