"""Inference: one IMU recording + one checkpoint -> velocities over spans of time -> a trajectory.

``predict_trajectory`` is the one function the CLI (``ftin predict``), the evaluation and the app
call. Steps and decisions:

1-2. Preparation (``ftin.data.prepare.prepare``, shared with training): orientation (the ``orientation``
   choice applied, ``ftin.data.orientation_option``; without one the sequence's own, else estimated by
   an attitude filter, with a note), then the checkpoint's ``imu_rate_hz``
   grid (resampled unless already on it), the world-frame IMU and the window starts. The prepared
   sequence comes back as ``Prediction.prepared``: callers read what the model saw from it.
3. Velocities, as each model's reference tests it (parts and streaming: ``ftin.models.base``):
   - Window models (RoNIN ResNet, TLIO, IMUNet, FTIN, RNIN): windows of ``window`` samples every
     ``stride`` samples (the checkpoint's stride unless given), exactly as in training
     (``ftin.data.windows``), streamed through the model in batches under ``torch.inference_mode``:
     only one batch of windows exists at a time (each batch is copied out of a strided view of the
     ``(N, 6)`` world-frame IMU), so window memory does not grow with the recording; feature taps
     (one row per window) are kept only when asked for. A model with K parts per window (RNIN: its
     1 s sub-windows) gives a velocity per part: the first window contributes all K parts, every
     later window only its last ``ceil(stride / part)`` parts (one for any stride up to a part,
     which is RNIN's test: the last sub-window of each sequence; more only so that a stride longer
     than a part leaves no gap). For K = 1 that is one velocity per window, as always. A recording
     shorter than the window but at least one part long runs one shorter window (fewer sub-windows).
   - Streaming models (RoNIN LSTM, TCN): the whole recording goes through ``forward_stream`` in
     chunks of ``batch_size * stride`` frames (at most ``STREAM_CHUNK_MAX_FRAMES``), carrying the
     state between chunks: the same per-frame velocities as the reference's single pass over the
     whole sequence, in bounded memory. Progress is reported (and a caller may cancel) per chunk, in
     frames; there are no windows, so no feature taps.
   The networks are not yaw-equivariant, so they are made so at inference (``ftin.yaw_average``):
   a window model of the families in ``CYCLIC_FAMILIES`` sees window k turned by k mod 4 quarter turns
   (``cyclic_turns``: one look per window) and its velocity is turned back; the other families, and
   every streaming model, average over
   ``yaw_copies`` (default ``YAW_COPIES``, 4) copies of the input turned by quarter turns, each turned
   back (``yaw_copies`` averages turned copies of a cycled window too; 1 without cyclic turns is the
   network alone). Feature taps are those of the input the model saw. ``precision``
   (``ftin.precision``): ``bf16`` runs the model's forward alone under bf16 autocast, its outputs
   cast back to float64 before the average; ``fp32`` (the default) runs it as trained.
   What grows with the recording is linear in the number of samples and small per sample: the
   resampled, rotated IMU, the velocities and the trajectory (``ftin bench memory`` measures
   the peak RSS of a 1-hour 200 Hz recording).
4. Integration: each velocity is the mean velocity over its span ``[t[a], t[b]]`` (a window, a part
   or one sample interval), so each sample interval ``[t[i], t[i+1]]`` gets the average velocity of
   the spans covering it (with non-overlapping spans this integrates each span's displacement
   exactly; per-frame velocities are integrated per sample interval). Intervals after the last span
   (fewer than ``stride`` samples) keep the last velocity. Positions start at the ground-truth start
   position when there is ground truth, else at the origin; with a 2-D model z stays at the start
   height, a 3-D model integrates z too. ``Prediction.window_t_s`` / ``velocity_m_s`` hold one time
   (the middle of the span) and one velocity per prediction, ``span_t_s`` the spans themselves.
4b. Body-locked heading (``ftin.body_heading``, phone-only orientations): where the network's
   direction does not follow the phone at all over the walk, or wanders while the phone is held flat
   in front, each window keeps its speed and takes the phone's heading plus one offset (a phone
   carried fixed to the body); a note says so and why.
5. Frames: with ground truth the estimate lives in the ground-truth world frame (readers align it
   with the device world frame at the start: ``docs/design.md``, "Frames"); without it, the estimate is in the
   device's own world frame (gravity-aligned, arbitrary yaw).
6. Scoring is not inference: ``ftin.evaluate.score(prediction)`` compares the trajectory with the
   prepared ground truth (``Prediction.truth``) under the alignment rules of
   ``ftin.metrics.alignment_modes``, for the CLI, the evaluation and the app alike, and returns a
   result of its own: a prediction is never written after it is returned.
7. ``keep_prepared=False`` keeps only the model's input (``imu_world``, ``starts``: 24 bytes a sample)
   instead of the whole prepared copy of the recording, for a server that keeps many results.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from ftin.body_heading import lock_to_phone
from ftin.checkpoint import LoadedModel
from ftin.data.errors import DataFormatError
from ftin.data.gaps import holes_of
from ftin.data.orientation_option import choice_of
from ftin.data.prepare import PreparedSequence, prepare
from ftin.data.types import ImuSequence, Trajectory
from ftin.data.windows import window_starts, window_view
from ftin.precision import Precision, forward_context
from ftin.yaw_average import (
    YAW_COPIES,
    cyclic_angles,
    default_copies,
    mean_turned_back,
    turn_log_std,
    turn_velocities,
    turn_windows,
    turned_copies,
    uses_cyclic_turns,
)

FRAME_GROUND_TRUTH = "ground_truth"
FRAME_DEVICE_WORLD = "device_world"
STREAM_CHUNK_MAX_FRAMES = 1 << 16  # frames per forward_stream call (TCN activations ~67 MB per layer)


@dataclass
class Prediction:
    trajectory: Trajectory
    window_t_s: np.ndarray  # (M,) middle of each prediction's span [t[a], t[b]]
    velocity_m_s: np.ndarray  # (M, D) world-frame mean velocity over each span
    orientation_source: str  # "device", "ground_truth" or "estimated"
    frame: str  # "ground_truth" or "device_world"
    warnings: list[str]  # what may be wrong with the result
    features: dict | None  # name -> (windows, ...) float32 feature taps, when asked (window models)
    span_t_s: np.ndarray | None = None  # (M, 2) start and end time of each prediction's span
    prepared: PreparedSequence | None = None  # what the model saw (ftin.data.prepare); see step 7
    # What scoring reads (ftin.evaluate.score): the ground truth on the prediction's grid, whether its
    # world frame is known to be the device's ("gt_frame"), and the model's window in seconds.
    truth: Trajectory | None = None
    truth_frame: str | None = None
    window_s: float | None = None
    orientation_filter: str | None = None  # which attitude filter ran (VQF 6-D or 9-D), when one did
    imu_world: np.ndarray | None = None  # (N, 6) float32 world-frame IMU the model read
    starts: np.ndarray | None = None  # (M,) first sample of each of the model's windows
    notes: list[str] = field(default_factory=list)  # how the input was read (gaps bridged, ...)
    # The orientation asked for, the source that ran and why (ftin.data.orientation_option), when asked.
    orientation_choice: dict[str, str] | None = None
    turn_stride: int | None = None  # windows turned by (start // turn_stride) mod 4 quarter turns


def predict_trajectory(
    loaded: LoadedModel,
    seq: ImuSequence,
    *,
    stride: int | None = None,
    batch_size: int = 1024,
    progress: Callable[[int, int], None] | None = None,
    return_features: bool = False,
    keep_prepared: bool = True,
    orientation: str | None = None,
    yaw_copies: int | None = None,
    precision: Precision | str = Precision.FP32,
    cyclic_turns: bool | None = None,
    body_lock: bool = True,
) -> Prediction:
    """Run ``loaded`` over ``seq`` and integrate a trajectory; see the module docstring. The result
    carries the prepared sequence (``Prediction.prepared``, unless ``keep_prepared`` is False) and
    what scoring reads, never metrics."""
    if batch_size < 1:
        raise ValueError(f"batch_size must be >= 1, got {batch_size}")
    stride = loaded.stride if stride is None else stride
    if stride < 1:
        raise ValueError(f"stride must be >= 1 sample, got {stride}")
    prepared = prepare(seq, loaded.imu_rate_hz, loaded.window, stride, orientation)
    streams = loaded.model.streams  # a stream has no window to turn
    cyclic = (
        uses_cyclic_turns(loaded.model_name, streams)
        if cyclic_turns is None
        else cyclic_turns and not streams
    )
    yaw_copies = default_copies(cyclic) if yaw_copies is None else yaw_copies
    notes = list(prepared.notes)  # what preparing did (resampled): information
    short: list[str] = []  # a model run on less than its window: a warning
    n, t_s = len(prepared), prepared.seq.t_s
    features = None
    if loaded.model.streams:
        _check_length(loaded, seq, n, 2, "two samples (one interval)")
        chunk = min(batch_size * stride, STREAM_CHUNK_MAX_FRAMES)
        velocity = _run_stream(loaded, prepared.imu_world, chunk, progress, yaw_copies, precision)  # (N-1, D)
        span_start = np.arange(n - 1)
        span_end = span_start + 1
    else:
        window, parts = _window_and_parts(loaded, seq, n, short)
        starts = prepared.starts if window == loaded.window else window_starts(n, window, stride)
        part_velocity, features = run_windows(
            loaded,
            prepared.imu_world,
            starts,
            window,
            parts,
            batch_size,
            progress,
            return_features,
            yaw_copies,
            precision,
            stride if cyclic else None,
        )
        span_start, span_end, velocity = select_parts(starts, window, stride, part_velocity)
    orientation_source = str(prepared.seq.meta.get("orientation_source", "device"))
    if body_lock and orientation_source != "ground_truth":
        lock = lock_to_phone(
            t_s, prepared.seq.q_world_device_wxyz, prepared.imu_world[:, 3:6], prepared.rate_hz,
            span_start, span_end, velocity,
        )  # fmt: skip
        velocity = lock.velocity_m_s
        notes += [lock.note()] if lock.locked else []
    gt = prepared.seq.gt
    start_m = gt.p_world_m[0] if gt is not None else np.zeros(3)
    holes = holes_of(prepared.seq)
    p_world_m = integrate_spans(t_s, *outside_holes(t_s, span_start, span_end, velocity, holes), start_m)
    return Prediction(
        trajectory=Trajectory(t_s.copy(), p_world_m, prepared.seq.q_world_device_wxyz),
        window_t_s=0.5 * (t_s[span_start] + t_s[span_end]),
        velocity_m_s=velocity,
        orientation_source=orientation_source,
        frame=FRAME_GROUND_TRUTH if gt is not None else FRAME_DEVICE_WORLD,
        warnings=[*prepared.seq.meta.get("warnings", []), *short],
        features=features,
        span_t_s=np.column_stack([t_s[span_start], t_s[span_end]]),
        prepared=prepared if keep_prepared else None,
        truth=gt,
        truth_frame=prepared.seq.meta.get("gt_frame"),
        window_s=loaded.window / float(loaded.imu_rate_hz),
        orientation_filter=prepared.seq.meta.get("orientation_filter"),
        imu_world=prepared.imu_world,
        starts=prepared.starts,
        notes=[*prepared.seq.meta.get("notes", []), *notes],
        orientation_choice=choice_of(prepared.seq),
        turn_stride=stride if cyclic else None,
    )


def _check_length(loaded: LoadedModel, seq: ImuSequence, n: int, needed: int, what: str) -> None:
    if n < needed:
        raise DataFormatError(
            f"sequence {seq.name!r} is too short: {n} samples at {loaded.imu_rate_hz:g} Hz, "
            f"checkpoint {loaded.name!r} needs at least {needed} ({what})"
        )


def _window_and_parts(loaded: LoadedModel, seq: ImuSequence, n: int, warnings: list[str]) -> tuple[int, int]:
    """The window to run and its number of parts; a multi-part model runs fewer parts on a recording
    shorter than its window (module docstring, step 3)."""
    window = loaded.window
    parts = loaded.model.target_parts(window)
    part = window // parts
    if n >= window + 1 or parts == 1:
        _check_length(loaded, seq, n, window + 1, f"a {window}-sample window and its end")
        return window, parts
    _check_length(loaded, seq, n, part + 1, f"one {part}-sample part of its window and its end")
    short = (n - 1) // part * part
    warnings.append(
        f"{seq.name}: shorter than {loaded.name!r}'s {window}-sample window; ran one window of "
        f"{short // part} of its {parts} parts"
    )
    return short, loaded.model.target_parts(short)


def select_parts(
    starts: np.ndarray, window: int, stride: int, part_velocity: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(span_start, span_end, velocity)`` of the parts that integrate (module docstring, step 3).

    ``part_velocity`` is ``(M, K, D)`` for the windows at ``starts``; the first window gives all K
    parts, each later one its last ``min(K, ceil(stride / part))``. Spans come out in time order.
    """
    n_windows, parts, dim = part_velocity.shape
    part = window // parts
    later = min(parts, -(-stride // part))
    offsets = np.arange(parts) * part  # (K,) part starts within a window
    first_start = starts[0] + offsets  # (K,)
    later_start = (starts[1:, None] + offsets[None, parts - later :]).reshape(-1)  # ((M-1) * later,)
    span_start = np.concatenate([first_start, later_start]).astype(np.int64)
    velocity = np.concatenate([part_velocity[0], part_velocity[1:, parts - later :].reshape(-1, dim)])
    return span_start, span_start + part, velocity


def outside_holes(
    t_s: np.ndarray,
    span_start: np.ndarray,
    span_end: np.ndarray,
    velocity_m_s: np.ndarray,
    holes_s: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The spans that see no hole in the recording (``ftin.data.gaps``: the data there is invented
    by interpolation), plus a zero-velocity span over each stretch no remaining span covers, so the
    trajectory holds its position across a hole instead of carrying the last velocity on."""
    if not len(holes_s):
        return span_start, span_end, velocity_m_s
    a, b = t_s[span_start], t_s[span_end]
    blind = ((a[:, None] < holes_s[None, :, 1]) & (b[:, None] > holes_s[None, :, 0])).any(axis=1)
    keep = ~blind
    covered = np.zeros(len(t_s) - 1, dtype=bool)
    for s, e in zip(span_start[keep], span_end[keep], strict=True):
        covered[s:e] = True
    last_end = int(span_end.max())
    fill_start = np.flatnonzero(~covered[:last_end])
    zero = np.zeros((len(fill_start), velocity_m_s.shape[1]))
    order = np.argsort(np.concatenate([span_start[keep], fill_start]), kind="stable")
    starts = np.concatenate([span_start[keep], fill_start])[order]
    ends = np.concatenate([span_end[keep], fill_start + 1])[order]
    velocity = np.concatenate([velocity_m_s[keep], zero])[order]
    return starts, ends, velocity


def integrate_windows(
    t_s: np.ndarray, starts: np.ndarray, window: int, velocity_m_s: np.ndarray, start_m: np.ndarray
) -> np.ndarray:
    """``(N, 3)`` positions from per-window mean velocities over ``[t[s], t[s + window]]``."""
    return integrate_spans(t_s, starts, np.asarray(starts) + window, velocity_m_s, start_m)


def integrate_spans(
    t_s: np.ndarray,
    span_start: np.ndarray,
    span_end: np.ndarray,
    velocity_m_s: np.ndarray,
    start_m: np.ndarray,
) -> np.ndarray:
    """``(N, 3)`` positions from mean velocities over spans ``[t[a], t[b]]`` (module docstring, step 4).

    Spans are in time order (the last one is the latest); every interval before the last span's end
    should be covered, an uncovered one keeps the last velocity.
    """
    n, d = len(t_s), velocity_m_s.shape[1]
    # Difference arrays: +v where a span begins, -v where it ends; the running sum over intervals is
    # then the sum of the velocities of all spans covering each interval. (np.add.at: a sample may
    # begin or end several spans.)
    delta = np.zeros((n, d))
    np.add.at(delta, span_start, velocity_m_s)
    np.add.at(delta, span_end, -velocity_m_s)
    count_delta = np.zeros(n)
    np.add.at(count_delta, span_start, 1.0)
    np.add.at(count_delta, span_end, -1.0)
    v_sum = np.cumsum(delta, axis=0)[: n - 1]  # (N - 1, D) per interval
    count = np.rint(np.cumsum(count_delta)[: n - 1])
    v_interval = np.empty((n - 1, d))
    covered = count > 0
    v_interval[covered] = v_sum[covered] / count[covered, None]
    v_interval[~covered] = velocity_m_s[-1]  # only the tail after the last span is uncovered
    p = np.tile(np.asarray(start_m, dtype=np.float64), (n, 1))
    steps = v_interval * np.diff(t_s)[:, None]  # (N - 1, D) displacement per interval
    p[1:, :d] += np.cumsum(steps, axis=0)
    return p


def run_windows(
    loaded: LoadedModel,
    imu: np.ndarray,
    starts: np.ndarray,
    window: int,
    parts: int,
    batch_size: int,
    progress: Callable[[int, int], None] | None,
    return_features: bool,
    yaw_copies: int = 1,
    precision: Precision | str = Precision.FP32,
    turn_stride: int | None = None,
) -> tuple[np.ndarray, dict | None]:
    """Part velocities ``(M, K, D)`` (float64) and, when asked, the concatenated per-window taps; a model
    with a variance head always adds its per-window ``log_std`` (M, D) to them (the path's uncertainty
    reads it: ``ftin.uncertainty``), so the dict is then never None.

    K = 1 models go through ``forward`` (their taps and log-std exactly as ever), others through
    ``forward_parts``. With ``turn_stride`` each window is first turned by ``start // turn_stride mod 4``
    quarter turns and its velocity (and log-std) turned back (``ftin.yaw_average.cyclic_angles``);
    velocities are the mean over ``yaw_copies`` turned copies of that window; taps are those of the
    window the model saw (copy 0). Under
    ``precision`` bf16 the forward alone runs in autocast; velocities and taps come back as float32 or
    wider.
    """
    model = loaded.model
    device = next(model.parameters()).device
    view = window_view(imu, window)  # (N - L + 1, 6, L), a view: no copy
    total = len(starts)
    velocity = np.empty((total, parts, loaded.out_dim))
    taps: dict[str, list[np.ndarray]] | None = {} if return_features else None
    log_stds: list[np.ndarray] = []

    def call(inputs: torch.Tensor, features: dict | None) -> Any:
        inputs = loaded.normalization.apply(inputs)
        with forward_context(precision):
            return (
                model(inputs, features=features)
                if parts == 1
                else model.forward_parts(inputs, features=features)
            )

    model.eval()
    with torch.inference_mode():
        for first in range(0, total, batch_size):
            batch_starts = starts[first : first + batch_size]
            x = torch.from_numpy(np.ascontiguousarray(view[batch_starts])).to(device)  # (B, 6, L)
            yaw = None if turn_stride is None else torch.from_numpy(cyclic_angles(batch_starts, turn_stride))
            if yaw is not None:
                x = turn_windows(x, yaw)
            features: dict | None = {} if return_features else None
            output = call(x, features)  # the window as the model saw it, with its taps
            batch_velocity = output.velocity.double().cpu().numpy()  # (B, D) or (B, K, D)
            if yaw_copies > 1:
                turned = call(turned_copies(x, yaw_copies)[len(x) :], None).velocity.double().cpu().numpy()
                batch_velocity = mean_turned_back(np.concatenate([batch_velocity, turned]), yaw_copies)
            if yaw is not None:  # turned back
                batch_velocity = turn_velocities(batch_velocity, -yaw.numpy())
                if output.log_std is not None:
                    output = output._replace(log_std=turn_log_std(output.log_std, -yaw))
            velocity[first : first + len(batch_starts)] = batch_velocity.reshape(len(batch_starts), parts, -1)
            if output.log_std is not None:
                log_stds.append(output.log_std.float().cpu().numpy())
            if taps is not None:
                for name, value in features.items():
                    taps.setdefault(name, []).append(value.detach().float().cpu().numpy())
            if progress is not None:
                progress(first + len(batch_starts), total)
    joined = None if taps is None else {name: np.concatenate(rows, axis=0) for name, rows in taps.items()}
    if log_stds:
        joined = {**(joined or {}), "log_std": np.concatenate(log_stds, axis=0)}
    return velocity, joined


def _run_stream(
    loaded: LoadedModel,
    imu: np.ndarray,
    chunk: int,
    progress: Callable[[int, int], None] | None,
    yaw_copies: int = YAW_COPIES,
    precision: Precision | str = Precision.FP32,
) -> np.ndarray:
    """Per-frame velocities ``(N - 1, D)`` (float64) of a streaming model over the whole recording.

    Frame i's velocity is over the interval ``[t[i], t[i+1]]``, so the last frame (which has no
    interval after it) is not run.
    """
    total = len(imu) - 1
    velocity = np.empty((total, loaded.out_dim))
    state = None
    for first in range(0, total, chunk):
        frames = imu[first : min(first + chunk, total)]  # (T, 6)
        velocity[first : first + len(frames)], state = stream_step(
            loaded, frames, state, yaw_copies, precision
        )
        if progress is not None:
            progress(first + len(frames), total)
    return velocity


def stream_step(
    loaded: LoadedModel,
    frames: np.ndarray,
    state: Any,
    yaw_copies: int = YAW_COPIES,
    precision: Precision | str = Precision.FP32,
) -> tuple[np.ndarray, Any]:
    """A streaming model's per-frame velocities ``(T, D)`` (float64) for the next ``(T, 6)`` world-frame
    frames, and the state to carry on: the mean over ``yaw_copies`` turned copies, which run as one
    batch with one state each (``ftin.yaw_average``); under bf16 the forward alone runs in autocast."""
    model = loaded.model
    device = next(model.parameters()).device
    model.eval()
    with torch.inference_mode():
        x = torch.from_numpy(np.ascontiguousarray(frames.T)).to(device)[None]  # (1, 6, T)
        inputs = loaded.normalization.apply(turned_copies(x, yaw_copies))
        with forward_context(precision):
            per_frame, state = model.forward_stream(inputs, state)
    return mean_turned_back(per_frame.double().cpu().numpy(), yaw_copies)[0], state
