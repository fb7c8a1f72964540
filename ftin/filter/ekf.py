"""An error-state EKF after TLIO (Liu et al., RSS 2020): the raw IMU integrated, a network's mean
velocity over a window as the measurement (``docs/filter.md`` has the equations).

The error state is ``[dtheta, dv, dp, dbg, dba]`` (15; then the network's speed scale where
``FilterConfig.speed_scale_std`` asks for it) for the evolving state, then ``[dtheta, dp]``
(6) per stochastic clone taken at a window's start; the window's end is the evolving state itself
(the update runs at that sample). The measurement is expressed in the clone's heading frame, so a
heading error never shows in an innovation: heading is unobservable, and the filter must not turn
the walk to please the network.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ftin.filter.state import (
    BA,
    BG,
    CLONE,
    POS,
    SCALE,
    THETA,
    VEL,
    FilterConfig,
    NominalState,
    hat,
    right_jacobian,
    rot_z,
    so3_exp,
    so3_log,
    yaw_jacobian,
    yaw_of,
)


def step(
    state: NominalState,
    gyro: np.ndarray,
    acc: np.ndarray,
    dt: float,
    gravity: float,
    gyro_next: np.ndarray | None = None,
    acc_next: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One IMU interval from ``state``: the next ``R``, ``v``, ``p``; the evolving error's transition
    ``A`` ``(n, n)`` (n: 15, 16 with the speed scale, which the IMU leaves alone); and how the gyro and
    accelerometer white noise ``(6,)`` (per interval, rad/s and m/s²) enters it, ``B`` ``(n, 6)``.

    Midpoint rule: the rate is the mean of the interval's two samples and the world acceleration the
    mean of the two ends' (each rotated by its own orientation). Without the next sample (``None``)
    it holds sample k over the interval; on a walking phone at 100 Hz that zero-order hold errs by
    1-2 cm/s a second, ten times an accelerometer's noise, which no consistent filter can ignore.
    """
    gyro_next = gyro if gyro_next is None else gyro_next
    acc_next = acc if acc_next is None else acc_next
    phi = (0.5 * (gyro + gyro_next) - state.bg) * dt
    R_next = state.R @ so3_exp(phi)
    f0, f1 = state.R @ (acc - state.ba), R_next @ (acc_next - state.ba)
    dv = 0.5 * (f0 + f1) * dt  # world-frame velocity change from the specific force
    a_dt = dv + np.array([0.0, 0.0, -gravity * dt])
    v_next = state.v + a_dt
    p_next = state.p + state.v * dt + 0.5 * a_dt * dt
    A = np.eye(state.evolving_dim)
    theta_bg = -R_next @ right_jacobian(phi) * dt  # how a gyro bias error turns R_next
    A[THETA, BG] = theta_bg
    A[VEL, THETA] = -hat(dv)
    A[VEL, BG] = -0.5 * dt * hat(f1) @ theta_bg  # the second end's rotation moves with the bias
    A[VEL, BA] = -0.5 * (state.R + R_next) * dt
    A[POS, THETA] = 0.5 * dt * A[VEL, THETA]
    A[POS, VEL] = np.eye(3) * dt
    A[POS, BG] = 0.5 * dt * A[VEL, BG]
    A[POS, BA] = 0.5 * dt * A[VEL, BA]
    B = np.zeros((state.evolving_dim, 6))  # the noise moves R, v, p as a bias of this interval would
    B[: BG.start, 0:3] = A[: BG.start, BG]
    B[: BG.start, 3:6] = A[: BG.start, BA]
    return R_next, v_next, p_next, A, B


def boxplus(state: NominalState, dx: np.ndarray) -> NominalState:
    """``state`` corrected by the error ``dx`` (evolving block, then one block per clone)."""
    out = state.copy()
    out.R = so3_exp(dx[THETA]) @ state.R
    out.v = state.v + dx[VEL]
    out.p = state.p + dx[POS]
    out.bg = state.bg + dx[BG]
    out.ba = state.ba + dx[BA]
    if state.k is not None:
        out.k = state.k + float(dx[SCALE])
    first = state.evolving_dim
    for k in range(len(state.clone_index)):
        block = dx[first + CLONE * k : first + CLONE * (k + 1)]
        out.clone_R[k] = so3_exp(block[:3]) @ state.clone_R[k]
        out.clone_p[k] = state.clone_p[k] + block[3:]
    return out


def boxminus(truth: NominalState, estimate: NominalState) -> np.ndarray:
    """The error ``dx`` with ``boxplus(estimate, dx) == truth`` (evolving block only)."""
    dx = np.zeros(estimate.evolving_dim)
    dx[THETA] = so3_log(truth.R @ estimate.R.T)
    dx[VEL] = truth.v - estimate.v
    dx[POS] = truth.p - estimate.p
    dx[BG] = truth.bg - estimate.bg
    dx[BA] = truth.ba - estimate.ba
    if estimate.k is not None:
        dx[SCALE] = truth.k - estimate.k
    return dx


def velocity_measurement(state: NominalState, clone: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(h, H)``: the mean velocity from clone ``clone`` to now, in the clone's heading frame
    (``Rz(yaw(R_i))^T (p - p_i) / dt``; its horizontal part times the speed scale ``k`` where the
    filter estimates one), and its Jacobian ``(3, dim)`` with respect to the error state."""
    R_i, p_i = state.clone_R[clone], state.clone_p[clone]
    Rz = rot_z(yaw_of(R_i))
    local = Rz.T @ (state.p - p_i)
    scale = np.array([1.0, 1.0, 1.0]) if state.k is None else np.array([state.k, state.k, 1.0])
    h = scale * local / dt
    first = state.evolving_dim
    H = np.zeros((3, first + CLONE * len(state.clone_index)))
    col = first + CLONE * clone
    H[:, POS] = Rz.T / dt
    H[:, col + 3 : col + 6] = -Rz.T / dt
    # d(Rz(psi)^T d)/d psi = (l_y, -l_x, 0) for l = Rz^T d, times d psi / d dtheta_i.
    H[:, col : col + 3] = np.outer(np.array([local[1], -local[0], 0.0]), yaw_jacobian(R_i)) / dt
    H *= scale[:, None]
    if state.k is not None:
        H[:2, SCALE] = local[:2] / dt
    return h, H


@dataclass
class UpdateResult:
    """One network update: the innovation, its covariance, the NIS and whether it was applied."""

    innovation: np.ndarray  # (3,)
    S: np.ndarray  # (3, 3)
    nis: float
    applied: bool


class ErrorStateEkf:
    """The filter: ``propagate`` per IMU sample, ``clone`` at a window's start, ``update`` at its end."""

    def __init__(
        self,
        config: FilterConfig,
        R0: np.ndarray,
        p0: np.ndarray | None = None,
        biases: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> None:
        """Start at orientation ``R0`` and position ``p0`` (zero), with gyro and accelerometer
        ``biases`` (zero; their uncertainty is ``config``'s either way)."""
        self.config = config
        p = np.zeros(3) if p0 is None else np.asarray(p0, dtype=np.float64).copy()
        k = None if config.speed_scale_std is None else 1.0
        self.state = NominalState(np.asarray(R0, dtype=np.float64).copy(), p=p, k=k)
        if biases is not None:
            self.state.bg, self.state.ba = (np.asarray(b, dtype=np.float64).copy() for b in biases)
        self.P = config.initial_covariance()
        self.evolving = config.evolving_dim

    @property
    def evolving_covariance(self) -> np.ndarray:
        return self.P[: self.evolving, : self.evolving]

    def propagate(
        self,
        gyro: np.ndarray,
        acc: np.ndarray,
        dt: float,
        gyro_next: np.ndarray | None = None,
        acc_next: np.ndarray | None = None,
    ) -> None:
        """One interval (``step``: midpoint rule when the next sample is given): the nominal state
        integrated, the covariance carried with the IMU noise and the bias random walks (densities
        turned into per-interval variances for ``dt``)."""
        cfg = self.config
        s = self.state
        s.R, s.v, s.p, A, B = step(s, gyro, acc, dt, cfg.gravity_m_s2, gyro_next, acc_next)
        noise = np.repeat([cfg.gyro_noise_rad_s_sqrt_hz**2 / dt, cfg.acc_noise_m_s2_sqrt_hz**2 / dt], 3)
        P, n = self.P, self.evolving
        P[:n, :] = A @ P[:n, :]
        P[:, :n] = P[:, :n] @ A.T
        P[:n, :n] += (B * noise) @ B.T
        walk = np.repeat([cfg.gyro_bias_walk_rad_s_sqrt_s**2, cfg.acc_bias_walk_m_s2_sqrt_s**2], 3) * dt
        P[BG.start : BA.stop, BG.start : BA.stop] += np.diag(walk)
        if s.k is not None:
            P[SCALE, SCALE] += cfg.speed_scale_walk_per_sqrt_s**2 * dt

    def update_heading(self, psi_ref: float, std_rad: float) -> UpdateResult:
        """Update with a heading reference (an orientation filter's, ``ftin.filter.run``): ``h = psi(R)``,
        ``H = d psi / d dtheta`` on the evolving orientation; the innovation wrapped to (-pi, pi]."""
        H = np.zeros((1, len(self.P)))
        H[0, THETA] = yaw_jacobian(self.state.R)
        innovation = np.array([np.angle(np.exp(1j * (psi_ref - yaw_of(self.state.R))))])
        R_meas = np.array([[std_rad**2]])
        PHt = self.P @ H.T
        S = H @ PHt + R_meas
        K = PHt / S[0, 0]
        self.state = boxplus(self.state, K @ innovation)
        I_KH = np.eye(len(self.P)) - K @ H
        self.P = I_KH @ self.P @ I_KH.T + K @ R_meas @ K.T
        self.P = 0.5 * (self.P + self.P.T)
        return UpdateResult(innovation, S, float(innovation[0] ** 2 / S[0, 0]), True)

    def clone(self, index: int) -> None:
        """Add a clone of the current orientation and position, tagged with sample ``index``."""
        s = self.state
        s.clone_index.append(index)
        s.clone_R.append(s.R.copy())
        s.clone_p.append(s.p.copy())
        n = len(self.P)
        J = np.zeros((CLONE, n))
        J[:3, THETA] = np.eye(3)
        J[3:, POS] = np.eye(3)
        JP = J @ self.P
        self.P = np.block([[self.P, JP.T], [JP, JP @ J.T]])

    def drop_clone(self, index: int) -> None:
        """Marginalise the clone tagged ``index`` out (its rows and columns leave the covariance)."""
        s = self.state
        k = s.clone_index.index(index)
        for items in (s.clone_index, s.clone_R, s.clone_p):
            del items[k]
        first = self.evolving
        keep = np.r_[0 : first + CLONE * k, first + CLONE * (k + 1) : len(self.P)]
        self.P = self.P[np.ix_(keep, keep)]

    def update(self, index: int, z: np.ndarray, R_meas: np.ndarray, dt: float) -> UpdateResult:
        """Update with ``z`` ``(3,)``: the mean velocity since the clone ``index``, in that clone's heading
        frame, with covariance ``R_meas`` ``(3, 3)``. Skipped (not applied) when the NIS exceeds the gate."""
        k = self.state.clone_index.index(index)
        h, H = velocity_measurement(self.state, k, dt)
        innovation = z - h
        PHt = self.P @ H.T
        S = H @ PHt + R_meas
        S = 0.5 * (S + S.T)
        nis = float(innovation @ np.linalg.solve(S, innovation))
        gate = self.config.gate_chi2
        if gate is not None and nis > gate:
            return UpdateResult(innovation, S, nis, False)
        K = np.linalg.solve(S, PHt.T).T  # P H^T S^-1 (S symmetric)
        self.state = boxplus(self.state, K @ innovation)
        # Joseph form: stays symmetric positive definite however the gain is rounded.
        I_KH = np.eye(len(self.P)) - K @ H
        self.P = I_KH @ self.P @ I_KH.T + K @ R_meas @ K.T
        self.P = 0.5 * (self.P + self.P.T)
        return UpdateResult(innovation, S, nis, True)
