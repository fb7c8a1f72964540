"""The EKF's parameters, its nominal state and the rotation algebra it needs (``docs/filter.md``).

Conventions (``docs/design.md``, "Frames"): ``R`` maps body (device) vectors into the gravity-aligned
world frame (z up); the accelerometer reads specific force, ``f = R^T (a - g)`` with ``g = (0, 0, -G)``.
Rotation errors are global (left) perturbations, ``R_true = Exp(dtheta) R_est``, with ``dtheta`` in
world axes, so that its z component is the heading error and its x, y components are the tilt error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

GRAVITY_M_S2 = 9.80665  # the simulator's and the readers' standard gravity (ftin.sim.imu)

# Error-state layout: the evolving block first, then one (theta, p) pair per clone.
THETA, VEL, POS, BG, BA = (slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15))
EVOLVING = 15
SCALE = 15  # the network's speed scale, after the biases, where the filter estimates one
CLONE = 6


MEASUREMENT_SIGMAS = ("auto", "fixed", "calibrated", "head")


@dataclass(frozen=True)
class FilterConfig:
    """Noise densities, initial uncertainty and the measurement options (defaults: a phone MEMS IMU,
    inflated for what the model leaves out: scale errors, misalignment, clock jitter).

    IMU noise is continuous-time (per sqrt(Hz)); bias random walks per sqrt(s). ``velocity_std_m_s``
    is the network's horizontal velocity error (one sigma per axis, fitted on validation; used when the
    model has no log-std head); ``vertical_std_m_s`` that of the pseudo-measurement "no mean vertical
    velocity over a window" (level floors), which keeps the vertical channel from drifting away.
    ``heading_std_rad``: with a heading reference (an orientation filter's causal heading, given to
    ``run_filter``) the filter takes it as a measurement at every update with this sigma; heading is
    unobservable from the network, and a gyro-only heading drifts with the bias the filter estimates
    from tilt-coupled evidence. ``update_every`` is the spacing of network updates in samples
    (``None``: one window, so that successive measurements do not share samples and their errors are
    closer to independent).

    ``speed_scale_std``: where set, the filter also estimates the network's speed scale ``k`` (the
    measurement reads ``k`` times the true horizontal velocity; start 1 with this sigma, a random walk
    of ``speed_scale_walk_per_sqrt_s``): a carry that damps the bounce is read slow by the network,
    while the integrated IMU's velocity changes at turns, starts and stops keep the true scale. ``None``
    (the default): no such state, the network's speed is taken as it is.
    """

    gyro_noise_rad_s_sqrt_hz: float = 1.0e-3
    acc_noise_m_s2_sqrt_hz: float = 2.0e-2
    gyro_bias_walk_rad_s_sqrt_s: float = 1.0e-4
    acc_bias_walk_m_s2_sqrt_s: float = 1.0e-3
    init_tilt_std_rad: float = np.radians(2.0)
    init_yaw_std_rad: float = np.radians(0.1)  # the start's heading defines the world: nothing to learn
    init_velocity_std_m_s: float = 1.0
    init_position_std_m: float = 1.0e-3
    init_gyro_bias_std_rad_s: float = 1.0e-2
    init_acc_bias_std_m_s2: float = 0.2
    velocity_std_m_s: float = 0.12  # the default's residual RMS: OxIOD 0.10, RIDI 0.15 (docs/filter.md)
    # "fixed" (velocity_std_m_s; the default: chosen on validation, docs/filter.md); "auto": the
    # model's variance head where it has one, else "fixed";
    # "calibrated", the position uncertainty's per-window sigma a + b|v|
    # (ftin.uncertainty.propagate.window_sigma); "head", the head's sigma times its calibrated
    # log_std_scale (ftin/uncertainty/calibration.json; 1 where none is fitted). Each times
    # measurement_sigma_scale but "fixed".
    measurement_sigma: str = "fixed"
    measurement_sigma_scale: float = 1.0
    vertical_std_m_s: float = 0.1
    update_every: int | None = None
    heading_std_rad: float | None = np.radians(2.0)  # a heading reference's sigma (None: own heading)
    heading_reference: str = "offline"  # "offline": the start orientation's; "causal": VQF forwards only
    gate_chi2: float | None = None  # Mahalanobis gate on the NIS (None: every update is applied)
    gravity_m_s2: float = GRAVITY_M_S2
    correct_network_input: bool = True  # the network reads bias-corrected IMU
    speed_scale_std: float | None = None
    speed_scale_walk_per_sqrt_s: float = 2.0e-3

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if (
                name
                in (
                    "update_every",
                    "gate_chi2",
                    "correct_network_input",
                    "heading_std_rad",
                    "heading_reference",
                    "measurement_sigma",
                )
                or value is None
            ):
                continue
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"FilterConfig.{name} must be a finite number > 0, got {value!r}")
        if self.heading_reference not in ("offline", "causal"):
            raise ValueError(
                f"FilterConfig.heading_reference must be offline or causal, got {self.heading_reference!r}"
            )
        if self.measurement_sigma not in MEASUREMENT_SIGMAS:
            raise ValueError(
                f"FilterConfig.measurement_sigma must be one of {', '.join(MEASUREMENT_SIGMAS)}, "
                f"got {self.measurement_sigma!r}"
            )
        if self.update_every is not None and self.update_every < 1:
            raise ValueError(f"FilterConfig.update_every must be >= 1 sample, got {self.update_every}")

    @property
    def evolving_dim(self) -> int:
        """Size of the evolving error state: 15, and 16 with the speed scale."""
        return EVOLVING + (self.speed_scale_std is not None)

    def initial_covariance(self) -> np.ndarray:
        """``(evolving_dim, evolving_dim)`` covariance of the evolving error state at the start."""
        tilt, yaw = self.init_tilt_std_rad**2, self.init_yaw_std_rad**2
        diag = np.concatenate(
            [
                [tilt, tilt, yaw],
                np.full(3, self.init_velocity_std_m_s**2),
                np.full(3, self.init_position_std_m**2),
                np.full(3, self.init_gyro_bias_std_rad_s**2),
                np.full(3, self.init_acc_bias_std_m_s2**2),
                [] if self.speed_scale_std is None else [self.speed_scale_std**2],
            ]
        )
        return np.diag(diag)


@dataclass
class NominalState:
    """The nominal (estimated) state: orientation, velocity, position, gyro and accelerometer biases,
    plus the clones (orientation and position at past window starts, keyed by sample index), and the
    network's speed scale ``k`` where the filter estimates one (``None``: not a state)."""

    R: np.ndarray  # (3, 3) world <- body
    v: np.ndarray = field(default_factory=lambda: np.zeros(3))
    p: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bg: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ba: np.ndarray = field(default_factory=lambda: np.zeros(3))
    clone_index: list[int] = field(default_factory=list)  # sample index of each clone, in order
    clone_R: list[np.ndarray] = field(default_factory=list)
    clone_p: list[np.ndarray] = field(default_factory=list)
    k: float | None = None

    @property
    def evolving_dim(self) -> int:
        return EVOLVING + (self.k is not None)

    def copy(self) -> NominalState:
        return NominalState(
            self.R.copy(),
            self.v.copy(),
            self.p.copy(),
            self.bg.copy(),
            self.ba.copy(),
            list(self.clone_index),
            [r.copy() for r in self.clone_R],
            [p.copy() for p in self.clone_p],
            self.k,
        )


_I3 = np.eye(3)


def hat(v: np.ndarray) -> np.ndarray:
    """The skew matrix ``[v]x`` with ``[v]x w = v x w``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def so3_exp(phi: np.ndarray) -> np.ndarray:
    """``Exp(phi)``: the rotation matrix of the rotation vector ``phi`` (Rodrigues)."""
    angle = math.sqrt(phi[0] ** 2 + phi[1] ** 2 + phi[2] ** 2)
    K = hat(phi)
    if angle < 1e-8:
        return _I3 + K + 0.5 * K @ K
    return _I3 + math.sin(angle) / angle * K + (1.0 - math.cos(angle)) / angle**2 * (K @ K)


def so3_log(R: np.ndarray) -> np.ndarray:
    """The rotation vector of ``R`` (inverse of ``so3_exp`` for angles below pi)."""
    cos = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-8:
        return 0.5 * axis
    return angle / (2.0 * np.sin(angle)) * axis


def right_jacobian(phi: np.ndarray) -> np.ndarray:
    """``J_r(phi)``: ``Exp(phi + d) ~= Exp(phi) Exp(J_r(phi) d)`` for a small ``d``."""
    angle = math.sqrt(phi[0] ** 2 + phi[1] ** 2 + phi[2] ** 2)
    K = hat(phi)
    if angle < 1e-8:
        return _I3 - 0.5 * K
    return _I3 - (1.0 - math.cos(angle)) / angle**2 * K + (angle - math.sin(angle)) / angle**3 * (K @ K)


def quat_of(R: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternion of ``R`` with ``w >= 0``."""
    w = 0.5 * np.sqrt(max(1.0 + R[0, 0] + R[1, 1] + R[2, 2], 0.0))
    if w > 1e-3:
        q = np.array(
            [w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)]
        )
    else:  # near a half turn: go through scipy's robust branch
        x, y, z, w = Rotation.from_matrix(R).as_quat()
        q = np.array([w, x, y, z])
    q /= np.linalg.norm(q)
    return -q if q[0] < 0 else q


def yaw_of(R: np.ndarray) -> float:
    """Heading of ``R``: the twist about world z of ``R = Rz(psi) S`` (``ftin.data.frames.yaw_rad``)."""
    q = quat_of(R)
    return float(2.0 * np.arctan2(q[3], q[0]))


def yaw_jacobian(R: np.ndarray) -> np.ndarray:
    """``(3,)``: d yaw / d dtheta for the global perturbation ``Exp(dtheta) R``.

    With ``q = (w, x, y, z)`` and ``psi = 2 atan2(z, w)``, a left rotation by ``dtheta`` moves
    ``w`` by ``-dtheta . (x, y, z) / 2`` and ``z`` by ``(y, -x, w) . dtheta / 2``; so the gradient is
    ``(w y + z x, z y - w x, w^2 + z^2) / (w^2 + z^2)``: the z axis alone for a level body.
    """
    w, x, y, z = quat_of(R)
    return np.array([w * y + z * x, z * y - w * x, w * w + z * z]) / (w * w + z * z)


def rot_z(psi: float) -> np.ndarray:
    c, s = np.cos(psi), np.sin(psi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
