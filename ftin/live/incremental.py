"""Inference on a growing recording: windows run as soon as their samples are in, and the trajectory
is extended in place, at a cost per new second of data that does not depend on the session's length.

``IncrementalPredictor.extend(t, gyro, acc, q)`` appends oriented samples on the model's clock;
``trajectory()``, ``spans()`` and ``imu_world()`` return views of what exists so far (no copies).

Decisions (the offline path is ``ftin.infer.predict_trajectory``; the result at the end of a stream is
the one it computes on the same samples):
- Window models: every window whose end sample exists runs once (``ftin.infer.run_windows``); the
  first window gives all its parts, later ones their last ``ceil(stride / part)`` (``select_parts``).
  Streaming models (RoNIN LSTM, TCN): new frames go through ``forward_stream`` with the state carried
  over, exactly as offline chunks do (``ftin.infer.stream_step``). Both are made yaw-equivariant as
  offline (``ftin.yaw_average``: a window turned into its own yaw, a stream's turned copies averaged).
- Integration (``ftin.infer.integrate_spans``) incrementally: an interval's velocity is the mean of the
  spans that cover it, and no later span starts before the latest span's start, so every interval
  before it is final and integrated once; the intervals after it (at most a window) are recomputed on
  each update, those past the last span's end with the last velocity, as offline.
- Arrays grow by doubling (amortised O(1) per sample, ``ftin.data.growing``); the difference arrays of the
  integration are kept only from the final point on.
"""

from __future__ import annotations

import numpy as np

from ftin.checkpoint import LoadedModel
from ftin.data import frames
from ftin.data.growing import Growing, GrowingWalk
from ftin.infer import run_windows, select_parts, stream_step
from ftin.yaw_average import default_copies, uses_cyclic_turns

BATCH_WINDOWS = 64


class IncrementalPredictor(GrowingWalk):
    def __init__(self, loaded: LoadedModel, stride: int | None = None) -> None:
        super().__init__()
        self.loaded = loaded
        cyclic = uses_cyclic_turns(loaded.model_name, loaded.model.streams)  # as offline
        self.turn_stride = loaded.stride if cyclic else None
        self.window = loaded.window
        self.stride = stride or loaded.stride
        self.dim = loaded.out_dim
        self.streams = bool(loaded.model.streams)
        self.parts = 1 if self.streams else loaded.model.target_parts(self.window)
        self.part = self.window // self.parts
        self.later = min(self.parts, -(-self.stride // self.part))
        self._imu = Growing(6, np.float32)  # beside the walk's samples (GrowingWalk): the model's rows
        self._span_start, self._span_end = Growing(None, np.int64), Growing(None, np.int64)
        self._velocity = Growing(self.dim)
        self._span_t = Growing(2)  # start and end time of every span
        self._mid_t = Growing(None)  # their middles (``Prediction.window_t_s``)
        self._window_starts = Growing(None, np.int64)
        # A variance head's per-window log-std (x, y), one row a span where a window is one span.
        self._log_std = Growing(2) if self.parts == 1 and loaded.model.has_uncertainty else None
        self._next_start = 0  # window models: the next window's first sample
        self._next_frame = 0  # streaming models: the next frame to run
        self._stream_state = None
        # Integration: intervals before ``_final`` are final; difference arrays from ``_final`` on.
        self._final = 0
        self._v_running = np.zeros(self.dim)
        self._c_running = 0.0
        self._final_length_m = 0.0  # horizontal path length up to the final point
        self._delta = np.zeros((0, self.dim))
        self._count = np.zeros(0)

    @property
    def n_spans(self) -> int:
        return len(self._velocity)

    @property
    def covered_until_s(self) -> float | None:
        """End time of the latest span: the data the model has seen (None before the first span)."""
        if not self.n_spans:
            return None
        return float(self._t.view()[self._span_end.view()[-1]])

    def extend(self, t_s: np.ndarray, gyro: np.ndarray, acc: np.ndarray, q_wxyz: np.ndarray) -> int:
        """Append samples (on the model's uniform clock, in order); returns the number of new spans."""
        rotation = frames.rotation_from_wxyz(q_wxyz)
        imu = np.concatenate([rotation.apply(gyro), rotation.apply(acc)], axis=1).astype(np.float32)
        self._t.extend(t_s)
        self._gyro.extend(gyro)
        self._acc.extend(acc)
        self._q_in.extend(q_wxyz)
        self._imu.extend(imu)
        self._p.extend(np.zeros((len(t_s), 3)))
        self._delta = np.concatenate([self._delta, np.zeros((len(t_s), self.dim))])
        self._count = np.concatenate([self._count, np.zeros(len(t_s))])
        before = self.n_spans
        if self.streams:
            self._run_stream()
        else:
            self._run_windows()
        if self.n_spans:  # the tail past the last span moves on with the last velocity, as offline
            self._integrate()
        return self.n_spans - before

    def log_std(self) -> np.ndarray | None:
        """``(spans, 2)`` the variance head's per-window log-std so far (a view), or None without one."""
        return None if self._log_std is None else self._log_std.view()

    # --- the model ------------------------------------------------------------------------------

    def _run_windows(self) -> None:
        n = len(self)
        last = n - 1 - self.window
        if last < self._next_start:
            return
        starts = np.arange(self._next_start, last + 1, self.stride, dtype=np.int64)
        self._next_start = int(starts[-1]) + self.stride
        part_velocity, taps = run_windows(
            self.loaded,
            self._imu.view(),
            starts,
            self.window,
            self.parts,
            BATCH_WINDOWS,
            None,
            False,
            default_copies(self.turn_stride is not None),
            turn_stride=self.turn_stride,
        )
        if len(self._window_starts) == 0:  # the first window gives all its parts
            span_start, span_end, velocity = select_parts(starts, self.window, self.stride, part_velocity)
        else:
            offsets = np.arange(self.parts - self.later, self.parts) * self.part
            span_start = (starts[:, None] + offsets[None, :]).reshape(-1)
            span_end = span_start + self.part
            velocity = part_velocity[:, self.parts - self.later :].reshape(-1, self.dim)
        self._window_starts.extend(starts)
        if self._log_std is not None:
            self._log_std.extend(taps["log_std"][:, :2])
        self._add_spans(span_start, span_end, velocity)

    def _run_stream(self) -> None:
        total = len(self) - 1  # frame i is the interval [t[i], t[i+1]]
        if total <= self._next_frame:
            return
        frames_ = self._imu.view()[self._next_frame : total]
        velocity, self._stream_state = stream_step(self.loaded, frames_, self._stream_state)
        span_start = np.arange(self._next_frame, total, dtype=np.int64)
        self._next_frame = total
        self._add_spans(span_start, span_start + 1, velocity)

    def _add_spans(self, start: np.ndarray, end: np.ndarray, velocity: np.ndarray) -> None:
        self._span_start.extend(start)
        self._span_end.extend(end)
        self._velocity.extend(velocity)
        t = self._t.view()
        span_t = np.column_stack([t[start], t[end]])
        self._span_t.extend(span_t)
        self._mid_t.extend(span_t.mean(axis=1))
        base = self._final
        np.add.at(self._delta, start - base, velocity)
        np.add.at(self._delta, end - base, -velocity)
        np.add.at(self._count, start - base, 1.0)
        np.add.at(self._count, end - base, -1.0)

    # --- integration ----------------------------------------------------------------------------

    def _integrate(self) -> None:
        """Commit the intervals that became final, recompute the provisional tail."""
        t, p = self._t.view(), self._p.view()
        n, base = len(t), self._final
        new_final = int(self._span_start.view()[-1])
        v_sum = self._v_running + np.cumsum(self._delta[: n - 1 - base], axis=0)
        count = np.rint(self._c_running + np.cumsum(self._count[: n - 1 - base]))
        v = np.empty_like(v_sum)
        covered = count > 0
        v[covered] = v_sum[covered] / count[covered, None]
        v[~covered] = self._velocity.view()[-1]
        steps = v * np.diff(t[base:])[:, None]
        p[base + 1 :, : self.dim] = p[base, : self.dim] + np.cumsum(steps, axis=0)
        # Intervals before the latest span's start are final: drop their difference rows.
        done = new_final - base
        if done > 0:
            self._final_length_m += _horizontal_length(p[base : new_final + 1])
            self._v_running = v_sum[done - 1].copy()
            self._c_running = float(count[done - 1])
            self._delta = self._delta[done:].copy()
            self._count = self._count[done:].copy()
            self._final = new_final

    def path_length_m(self) -> float:
        """Horizontal path length so far (the final part summed once, the tail each time)."""
        return self._final_length_m + _horizontal_length(self._p.view()[self._final :])

    # --- views ----------------------------------------------------------------------------------

    def imu_world(self) -> np.ndarray:
        return self._imu.view()

    def window_starts(self) -> np.ndarray:
        return self._window_starts.view()

    def span_times(self) -> tuple[np.ndarray, np.ndarray]:
        """``(mid (M,), start and end (M, 2))`` times of the spans, as ``Prediction`` holds them."""
        return self._mid_t.view(), self._span_t.view()

    def spans(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(span_start, span_end, velocity)``, sample indices and ``(M, D)`` mean velocities."""
        return self._span_start.view(), self._span_end.view(), self._velocity.view()

    @property
    def nbytes(self) -> int:
        grown = (
            self._t,
            self._gyro,
            self._acc,
            self._q_in,
            self._imu,
            self._p,
            self._span_start,
            self._span_end,
        )
        return sum(g.nbytes for g in (*grown, self._velocity, self._window_starts)) + self._delta.nbytes


def _horizontal_length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points[:, :2], axis=0), axis=1).sum()) if len(points) > 1 else 0.0
