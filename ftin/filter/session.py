"""The EKF as a stream: samples in, in time order and in chunks of any size, the filter's per-sample
estimates out as they come (``docs/filter.md``, "Live sessions"). ``run_filter`` (``ftin.filter.run``)
is this session fed a whole recording at once: one stepping core, so the per-sample outputs after
any chunking are those of the whole recording.

Per sample k (on the model's rate grid), ``_step``: the state is propagated from k - 1 to k with both
samples (midpoint rule); then the update of any window ending at k (the network reads that window's
world-frame rows, each built with the filter's orientation and biases at its own sample, so only
samples before k), and the heading reference's update; then the outputs at k are recorded; then a
clone is taken if a window starts at k; then row k of the network's input is built. Nothing at k
waits for sample k + 1, and nothing recorded is revised later: the filter is causal by construction.

A clone is taken at every window start, also one whose window the stream never completes (a whole
recording's last): it changes no estimate (the propagation and updates of the evolving state do not
read it), it only sits in the covariance until the stream ends.

``update(t, gyro, acc, heading)`` takes a heading reference per sample (or none); ``extend(t, gyro,
acc, q)`` is the live shape (``ftin.live.incremental.IncrementalPredictor.extend``): ``q`` is a causal
orientation (the phone's own, or VQF run forwards), whose first sample starts the filter and whose
heading is the reference. The views (``result``, ``positions``, ...) are of growing arrays, no copies.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.growing import Growing, GrowingWalk
from ftin.filter.ekf import ErrorStateEkf
from ftin.filter.state import POS, THETA, FilterConfig, rot_z, yaw_of

# measure(rows, start, end, R_start) -> (world velocity (3,), horizontal covariance (2, 2))
Measure = Callable[[np.ndarray, int, int, np.ndarray], tuple[np.ndarray, np.ndarray]]


@dataclass
class FilterRun:
    """What the filter estimated, per sample ``(N, ...)`` and per update ``(M, ...)``."""

    t_s: np.ndarray  # (N,)
    p_world_m: np.ndarray  # (N, 3) position after any update at that sample
    velocity_state_m_s: np.ndarray  # (N, 3) the filter's own velocity
    q_world_device_wxyz: np.ndarray  # (N, 4) the filter's orientation
    gyro_bias_rad_s: np.ndarray  # (N, 3)
    acc_bias_m_s2: np.ndarray  # (N, 3)
    position_cov_xy: np.ndarray  # (N, 2, 2) horizontal position covariance
    tilt_cov: np.ndarray  # (N, 2, 2) covariance of the tilt error (world x, y rotation)
    imu_world: np.ndarray  # (N, 6) float32: the rows the network read
    update_span: np.ndarray  # (M, 2) first and end sample of each update's window
    velocity_m_s: np.ndarray  # (M, D) the network's world-frame velocity of each window
    nis: np.ndarray  # (M,) normalised innovation squared (3 dof)
    applied: np.ndarray  # (M,) bool: False where the gate refused the update
    covariance: np.ndarray  # (M, n, n) evolving-state covariance after each update (n: 15, 16 with k)
    speed_scale: np.ndarray  # (N,) the network's speed scale the filter estimated (1 where it does not)


class FilterSession(GrowingWalk):
    """One stream through ``ErrorStateEkf`` with ``measure`` (or ``network(rows[start:end])``) as the
    window measurement. ``start_q_wxyz``: the start orientation (else ``extend``'s first sample);
    ``start_biases``: the gyro and accelerometer biases to start from (zero; ``ftin.filter.settle``);
    ``on_update(k)`` is called after every network update (a server checks its deadline there)."""

    # What a live run's ModelInput needs (app.services.live): a window model, each window read in its
    # own four yaw copies (ftin.filter.run.NetworkVelocity), never turned by its start.
    streams = False
    turn_stride = None

    def __init__(
        self,
        network: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None,
        window: int,
        config: FilterConfig | None = None,
        *,
        start_q_wxyz: np.ndarray | None = None,
        start_position_m: np.ndarray | None = None,
        start_biases: tuple[np.ndarray, np.ndarray] | None = None,
        measure: Measure | None = None,
        on_update: Callable[[int], None] | None = None,
    ) -> None:
        super().__init__()
        self.config = config or FilterConfig()
        self.window = int(window)
        self.every = self.config.update_every or self.window
        if measure is None:
            if network is None:
                raise ValueError("the filter needs a network or a measure function")

            def measure(rows: np.ndarray, start: int, end: int, _: np.ndarray) -> Any:
                return network(rows[start:end])

        self.measure, self.on_update = measure, on_update
        self._start_q = None if start_q_wxyz is None else np.asarray(start_q_wxyz, dtype=np.float64)
        self._start_p = np.zeros(3) if start_position_m is None else np.asarray(start_position_m, float)
        self._start_biases = start_biases
        self.ekf: ErrorStateEkf | None = None
        self._last: tuple[float, np.ndarray, np.ndarray] | None = None  # (t, gyro, acc) of sample k - 1
        self._clones: dict[int, tuple[np.ndarray, float]] = {}  # start -> the R and heading of its rows
        self._last_heading: float | None = None  # extend: the reference unwrapped across chunks
        self._chunk_t, self._chunk_first = np.zeros(0), 0
        self._length_m = 0.0
        # Per sample, beside the walk's (GrowingWalk).
        self._rows = Growing(6, np.float32)
        self._v, self._q = Growing(3), Growing(4)
        self._bg, self._ba, self._pos_cov, self._tilt_cov = Growing(3), Growing(3), Growing(4), Growing(4)
        self._k = Growing(None)
        # Per update.
        self._span, self._velocity = Growing(2, np.int64), Growing(3)
        self._nis, self._applied = Growing(None), Growing(None, bool)
        self._cov = Growing(self.config.evolving_dim**2)

    # --- input -----------------------------------------------------------------------------------

    def update(
        self, t_s: np.ndarray, gyro: np.ndarray, acc: np.ndarray, heading_rad: np.ndarray | None = None
    ) -> int:
        """Append samples ``(n,)``, ``(n, 3)``, ``(n, 3)`` (device frame, after the last one in time) with
        an optional heading reference ``(n,)`` in the start's world; returns the number of new updates."""
        t_s = np.asarray(t_s, dtype=np.float64)
        gyro, acc = np.asarray(gyro, dtype=np.float64), np.asarray(acc, dtype=np.float64)
        m, first = len(t_s), len(self)
        if m == 0:
            return 0
        if self._start_q is None:
            raise ValueError("the filter has no start orientation: give start_q_wxyz, or use extend")
        use_heading = heading_rad is not None and self.config.heading_std_rad is not None
        before = len(self._nis)
        self._chunk_t, self._chunk_first = t_s, first  # the times of samples stepped but not yet recorded
        R = np.zeros((m, 3, 3))
        # Room for the chunk first: the network reads rows of this chunk while it is being stepped.
        self._rows.extend(np.zeros((m, 6), dtype=np.float32))
        rows = self._rows.view()
        out = {name: np.zeros((m, 3)) for name in ("p", "v", "bg", "ba")}
        pos_cov, tilt_cov, k = np.zeros((m, 4)), np.zeros((m, 4)), np.ones(m)
        for i in range(m):
            heading = float(heading_rad[i]) if use_heading else None
            s, P = self._step(first + i, float(t_s[i]), gyro[i], acc[i], heading, rows)
            out["p"][i], out["v"][i], R[i], out["bg"][i], out["ba"][i] = s.p, s.v, s.R, s.bg, s.ba
            if s.k is not None:
                k[i] = s.k
            pos_cov[i], tilt_cov[i] = P[POS, POS][:2, :2].ravel(), P[THETA, THETA][:2, :2].ravel()
        q = frames.wxyz_from_rotation(Rotation.from_matrix(R))
        previous = self._q.view()[-1:]
        q = frames.make_continuous(np.vstack([previous, q]))[len(previous) :]  # one hemisphere throughout
        p_before = self._p.view()[-1:]
        steps = np.diff(np.vstack([p_before, out["p"]])[:, :2], axis=0)
        self._length_m += float(np.linalg.norm(steps, axis=1).sum())
        self._t.extend(t_s)
        self._gyro.extend(gyro)
        self._acc.extend(acc)
        self._q.extend(q)
        for buffer, name in ((self._p, "p"), (self._v, "v"), (self._bg, "bg"), (self._ba, "ba")):
            buffer.extend(out[name])
        self._pos_cov.extend(pos_cov)
        self._tilt_cov.extend(tilt_cov)
        self._k.extend(k)
        return len(self._nis) - before

    def extend(self, t_s: np.ndarray, gyro: np.ndarray, acc: np.ndarray, q_wxyz: np.ndarray) -> int:
        """The live shape: samples with their causal orientation ``(n, 4)``, whose first sample starts the
        filter and whose heading is the reference (``heading_reference='causal'``: the phone's own
        attitude, or VQF run forwards, ``ftin.live.orientation``); returns the number of new updates."""
        q_wxyz = np.asarray(q_wxyz, dtype=np.float64)
        if not len(q_wxyz):
            return 0
        if self._start_q is None:
            self._start_q = q_wxyz[0].copy()
        psi = frames.yaw_rad(q_wxyz)
        if self._last_heading is not None:  # unwrapped across chunks as over the whole stream
            psi = np.unwrap(np.concatenate([[self._last_heading], psi]))[1:]
        else:
            psi = np.unwrap(psi)
        self._last_heading = float(psi[-1])
        self._q_in.extend(q_wxyz)
        return self.update(t_s, gyro, acc, psi)

    def _step(
        self, k: int, t: float, gyro: np.ndarray, acc: np.ndarray, heading: float | None, rows: np.ndarray
    ):
        """Sample ``k``: propagate to it, update with any window ending at it, clone, build its row.
        Returns the state and covariance at ``k`` (after its updates, before its clone)."""
        cfg = self.config
        if self.ekf is None:
            R0 = frames.rotation_from_wxyz(self._start_q).as_matrix()
            self.ekf = ErrorStateEkf(cfg, R0, self._start_p, self._start_biases)
        else:
            t0, gyro0, acc0 = self._last
            self.ekf.propagate(gyro0, acc0, t - t0, gyro, acc)
        self._last = (t, gyro, acc)
        ekf = self.ekf
        start = k - self.window
        if start >= 0 and start % self.every == 0:
            R_start, yaw_start = self._clones.pop(start)
            v_world, cov_xy = self.measure(rows, start, k, R_start)
            Rz = rot_z(yaw_start)
            z = Rz.T @ v_world  # into the frame of the clone's heading (the measurement's frame)
            R_meas = np.zeros((3, 3))
            R_meas[:2, :2] = Rz[:2, :2].T @ cov_xy @ Rz[:2, :2]
            R_meas[2, 2] = cfg.vertical_std_m_s**2
            t_start = self._t_at(start)
            result = ekf.update(start, z, R_meas, t - t_start)
            ekf.drop_clone(start)
            if heading is not None:
                ekf.update_heading(heading, cfg.heading_std_rad)
            self._span.extend(np.array([[start, k]], dtype=np.int64))
            self._velocity.extend(np.asarray(v_world, dtype=np.float64)[None, :3])
            self._nis.extend(np.array([result.nis]))
            self._applied.extend(np.array([result.applied]))
            self._cov.extend(ekf.evolving_covariance.reshape(1, -1))
            if self.on_update is not None:
                self.on_update(k)
        s, P = ekf.state, ekf.evolving_covariance.copy()
        R_k = s.R.copy()
        if k % self.every == 0:
            self._clones[k] = (R_k, yaw_of(R_k))
            ekf.clone(k)
        w, f = (gyro - s.bg, acc - s.ba) if cfg.correct_network_input else (gyro, acc)
        rows[k, :3], rows[k, 3:] = R_k @ w, R_k @ f
        return s, P

    def _t_at(self, k: int) -> float:
        """The time of sample ``k``, recorded already or in the chunk being stepped."""
        if k < self._chunk_first:
            return float(self._t.view()[k])
        return float(self._chunk_t[k - self._chunk_first])

    # --- output ----------------------------------------------------------------------------------

    def result(self) -> FilterRun:
        """Everything so far (views of the growing arrays)."""
        n, m = len(self), len(self._nis)
        return FilterRun(
            t_s=self._t.view(),
            p_world_m=self._p.view(),
            velocity_state_m_s=self._v.view(),
            q_world_device_wxyz=self._q.view(),
            gyro_bias_rad_s=self._bg.view(),
            acc_bias_m_s2=self._ba.view(),
            position_cov_xy=self._pos_cov.view().reshape(n, 2, 2),
            tilt_cov=self._tilt_cov.view().reshape(n, 2, 2),
            imu_world=self._rows.view()[:n],
            update_span=self._span.view(),
            velocity_m_s=self._velocity.view(),
            nis=self._nis.view(),
            applied=self._applied.view(),
            covariance=self._cov.view().reshape(m, self.config.evolving_dim, self.config.evolving_dim),
            speed_scale=self._k.view(),
        )

    @property
    def n_spans(self) -> int:
        """Network updates so far (a live run exists from the first one on)."""
        return len(self._nis)

    @property
    def covered_until_s(self) -> float | None:
        """The latest sample's time once the first update ran: the filter's estimate there is final."""
        return float(self._t.view()[-1]) if self.n_spans else None

    def path_length_m(self) -> float:
        """Horizontal path length so far (each step summed once: nothing recorded moves later)."""
        return self._length_m

    def imu_world(self) -> np.ndarray:
        return self._rows.view()[: len(self)]

    def window_starts(self) -> np.ndarray:
        return self._span.view()[:, 0]

    def spans(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(span_start, span_end, velocity)`` of the updates: sample indices, ``(M, 3)`` velocities."""
        span = self._span.view()
        return span[:, 0], span[:, 1], self._velocity.view()

    def span_times(self) -> tuple[np.ndarray, np.ndarray]:
        """``(mid (M,), start and end (M, 2))`` times of the updates' windows (copies: O(M))."""
        span = self._span.view()
        t = self._t.view()
        span_t = np.column_stack([t[span[:, 0]], t[span[:, 1]]]) if len(span) else np.zeros((0, 2))
        return span_t.mean(axis=1), span_t
