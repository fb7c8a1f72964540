"""Training augmentations beyond random yaw, each off unless the config names it with a magnitude.

``TrainConfig.augment`` maps a name of ``AUGMENTATIONS`` to its magnitude (``None``: the default
below). Every draw is made per window out of ``(seed, epoch, window index)`` like the yaw angle
(``ftin.data.windows``), so a batch's augmentation depends neither on the batch order nor on the
process that draws it. Inputs are world-frame windows ``(B, 6, L)``, gyro xyz then acc xyz.

Decisions:
- ``shift`` (RoNIN): each window's start moves by up to ``± magnitude x stride`` samples (RoNIN:
  half its step), kept inside its own sequence; the targets follow the shifted window.
- ``acc_bias`` / ``gyro_bias`` (TLIO): a constant offset per window and axis, uniform in
  ``± magnitude`` (TLIO: 0.2 m/s², 0.05 rad/s), added in the gravity-aligned frame as TLIO adds it to
  its gravity-aligned features.
- ``tilt`` (TLIO's gravity perturbation): the whole window rotated about a random horizontal axis by
  up to ``magnitude`` degrees (5); the targets are not rotated: the input's gravity is off, the motion
  is not.
- ``acc_noise`` / ``gyro_noise`` (RNIN): white Gaussian noise of std ``magnitude`` on every sample
  (our values: 0.1 m/s², 0.01 rad/s, a few times a phone IMU's noise density at 100 Hz).
- ``vertical`` (ours): the zero-mean part of the vertical specific force (the bounce) scaled by a
  factor uniform in ``1 ± magnitude`` (0.7-1.3). The horizontal motion, and so the target, is
  untouched: gait and carry change the bounce at a given speed, so the bounce alone must not be read
  as speed. Its window mean (gravity) stays.
- ``mirror`` (ours): with probability ``magnitude`` (0.5) the window is reflected through a vertical
  plane: acceleration and target velocity change the sign of their y component, the gyroscope (an axial
  vector) those of x and z. The mirror image of a walk is a walk (the bag on the other shoulder, the
  loop turned the other way); a model must not learn the side a carrier swings to, nor a preferred
  turning direction, from a few walkers. Before yaw, which then turns the plane anywhere.
- ``orientation`` (ours): the error of a phone's own attitude estimate over one window: a heading
  error ramping linearly from 0 to up to ``± magnitude`` degrees (3) across the window, and a tilt
  about a random horizontal axis ramping to up to half that (gravity keeps tilt better observed than
  heading). The error starts at 0, so the window's start frame is the true one and the targets stay.
- ``pace`` (ours): the walk played faster or slower. Window k is read from a span of ``f x L``
  samples (``f`` log-uniform in ``[1 / (1 + magnitude), 1 + magnitude]``, 0.3: 0.77-1.3) and scaled
  as a motion played ``f`` times as fast is: angular rate x f, the zero-mean part of the specific
  force x f² (its window mean, gravity, stays), target velocity x f. Cadence, bounce and speed change
  together, as between a slow and a brisk gait, so neither the bounce nor the rhythm alone is the
  speed; and speeds that few training walks reach (running) are seen. A window never stretches past
  its sequence's end, a held hole, or an untracked ground-truth sample (``ftin.data.windows``).
- ``stride_length`` (ours): the walk with its horizontal motion stretched at the same cadence and bounce: the
  horizontal specific force (gravity-aligned frame, x and y, window mean included) and the target
  velocity x ``s``, ``s`` log-uniform in ``[1 / (1 + magnitude), 1 + magnitude]`` (0.3: 0.77-1.3). The
  angular rate and the vertical stay. Kinematically exact (the position track scaled about the vertical
  axis), so a window's horizontal swing, not its bounce or rhythm, tells a long stride from a short one:
  the networks read long strides short (issue 54) and move their speed by under 2 % when the
  along-track swing is 1.5x (``docs/results/probes/speed_cues_walking.md``). In no recipe: in a
  fine-tune it read the ILC floors (a phone held flat) shorter (``docs/results/probes/stride_length.md``).
Order: pace (which samples a window reads), then mirror, stride length and vertical (motion) before yaw
(done by the dataset), then orientation and tilt (the input's rotation), then bias and noise (the sensor).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

# name -> default magnitude (units in the module docstring)
AUGMENTATIONS: dict[str, float] = {
    "shift": 0.5,  # strides
    "acc_bias": 0.2,  # m/s²
    "gyro_bias": 0.05,  # rad/s
    "tilt": 5.0,  # degrees
    "acc_noise": 0.1,  # m/s²
    "gyro_noise": 0.01,  # rad/s
    "vertical": 0.3,  # fraction: scale in [1 - m, 1 + m]
    "orientation": 3.0,  # degrees of heading error at the window's end
    "mirror": 0.5,  # probability that a window is mirrored
    "pace": 0.3,  # the walk up to 1.3x faster or slower (log-uniform)
    "stride_length": 0.3,  # the horizontal motion up to 1.3x longer or shorter (log-uniform)
}
# One RNG stream per augmentation; a new one goes last, so the draws of the others never move.
_SALT = {name: i + 1 for i, name in enumerate(AUGMENTATIONS)}


def resolve_augment(augment: Mapping[str, Any] | None) -> dict[str, float]:
    """``{name: magnitude}`` with defaults filled in; ``ValueError`` naming an unknown or bad entry."""
    resolved: dict[str, float] = {}
    for name, value in dict(augment or {}).items():
        if name not in AUGMENTATIONS:
            raise ValueError(f"unknown augmentation {name!r}; known: {', '.join(AUGMENTATIONS)}")
        magnitude = AUGMENTATIONS[name] if value is None else value
        if isinstance(magnitude, bool) or not isinstance(magnitude, (int, float)) or not magnitude > 0:
            raise ValueError(f"augmentation {name}: magnitude must be a number > 0, got {value!r}")
        if name == "mirror" and magnitude > 1:
            raise ValueError(f"augmentation mirror: magnitude is a probability (<= 1), got {value}")
        if name == "vertical" and magnitude >= 1:
            raise ValueError(f"augmentation vertical: magnitude must be < 1 (a scale 1 ± m), got {value}")
        resolved[name] = float(magnitude)
    return resolved


def parse_augment(items: list[str]) -> dict[str, float | None]:
    """CLI form ``["tilt", "vertical=0.2"]`` -> ``{"tilt": None, "vertical": 0.2}``."""
    parsed: dict[str, float | None] = {}
    for item in items:
        name, _, value = item.partition("=")
        try:
            parsed[name.strip()] = float(value) if value else None
        except ValueError:
            raise ValueError(f"augmentation {item!r}: the magnitude after '=' must be a number") from None
    return parsed


def scale_acc_component(x: np.ndarray, direction: np.ndarray, factor: np.ndarray | float) -> np.ndarray:
    """Windows ``(B, 6, L)`` with the zero-mean part of the acceleration along the unit vectors
    ``direction (B, 3)`` (or one ``(3,)``) scaled by ``factor`` (per window or one); its window mean,
    the other components and the gyro stay. Returns a new array."""
    x = np.array(x, copy=True)
    u = np.broadcast_to(np.asarray(direction, dtype=np.float64), (len(x), 3))
    acc = x[:, 3:6, :].astype(np.float64)
    along = np.einsum("bi,bil->bl", u, acc)  # (B, L)
    wobble = along - along.mean(axis=1, keepdims=True)
    gain = np.broadcast_to(np.asarray(factor, dtype=np.float64), (len(x),))[:, None] - 1.0
    x[:, 3:6, :] = acc + u[:, :, None] * (gain * wobble)[:, None, :]
    return x


def rotate_windows(x: np.ndarray, rotation: Rotation, per_sample: bool = False) -> np.ndarray:
    """Gyro and acc of ``(B, 6, L)`` rotated by one rotation per window (``B``) or per sample
    (``B * L``, window-major, with ``per_sample``)."""
    b, _, length = x.shape
    m = rotation.as_matrix().astype(np.float64)
    m = m.reshape(b, length, 3, 3) if per_sample else np.broadcast_to(m[:, None], (b, length, 3, 3))
    out = np.empty_like(x)
    for first in (0, 3):
        out[:, first : first + 3, :] = np.einsum("blij,bjl->bil", m, x[:, first : first + 3, :])
    return out


@dataclass(frozen=True)
class WindowAugmenter:
    """The augmentations of one training dataset; ``WindowDataset`` calls ``shift_starts`` and
    ``before_yaw`` / ``after_yaw`` on each batch."""

    magnitudes: dict[str, float]
    stride: int
    seed: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "magnitudes", resolve_augment(self.magnitudes))

    def __bool__(self) -> bool:
        return bool(self.magnitudes)

    def _rng(self, name: str, epoch: int, index: int) -> np.random.Generator:
        return np.random.default_rng([self.seed, epoch, _SALT[name], int(index)])

    def _uniform(self, name: str, epoch: int, indices: np.ndarray, size: int) -> np.ndarray:
        """``(B, size)`` draws in [-1, 1), one stream per window index."""
        return np.stack([self._rng(name, epoch, i).uniform(-1.0, 1.0, size) for i in indices])

    def _log_uniform(self, name: str, epoch: int, indices: np.ndarray) -> np.ndarray:
        """``(B,)`` factors log-uniform in ``[1 / (1 + m), 1 + m]``, ``m`` the magnitude of ``name``."""
        draw = self._uniform(name, epoch, indices, 1)[:, 0]
        return np.exp(np.log1p(self.magnitudes[name]) * draw)

    def shift_starts(
        self, starts: np.ndarray, lowest: np.ndarray, highest: np.ndarray, indices: np.ndarray, epoch: int
    ) -> np.ndarray:
        """Window starts moved by up to ``± shift x stride`` samples, clipped to ``[lowest, highest]``."""
        if "shift" not in self.magnitudes:
            return starts
        reach = int(round(self.magnitudes["shift"] * self.stride))
        if reach == 0:
            return starts
        steps = np.array([self._rng("shift", epoch, i).integers(-reach, reach + 1) for i in indices])
        return np.clip(starts + steps.astype(np.int64), lowest, highest)

    def pace_factors(
        self, indices: np.ndarray, epoch: int, reach: np.ndarray, window: int
    ) -> np.ndarray | None:
        """``(B,)`` how many windows' worth of samples each window reads (None: pace is off), at most
        ``reach / window`` (the samples each start may read)."""
        if "pace" not in self.magnitudes:
            return None
        factors = self._log_uniform("pace", epoch, indices)
        return np.minimum(factors, np.asarray(reach, dtype=np.float64) / window)

    @staticmethod
    def pace(x: np.ndarray, v: np.ndarray, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Windows ``(B, 6, L)`` read from spans of ``factors`` windows, and their targets (the span's
        velocity), as the motion played ``factors`` times as fast (module docstring). New arrays."""
        f = np.asarray(factors, dtype=np.float64)[:, None, None]
        x = np.array(x, dtype=np.float64)
        x[:, :3, :] *= f
        acc = x[:, 3:6, :]
        mean = acc.mean(axis=2, keepdims=True)
        x[:, 3:6, :] = mean + (acc - mean) * f**2
        v = np.asarray(v, dtype=np.float64) * f.reshape((-1,) + (1,) * (np.ndim(v) - 1))
        return x.astype(np.float32), v.astype(np.float32)

    def mirror(
        self, x: np.ndarray, v: np.ndarray, indices: np.ndarray, epoch: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Windows ``(B, 6, L)`` and targets ``(B, [K,] D)`` reflected through the x-z plane, each with
        probability ``mirror`` (module docstring). Returns new arrays."""
        if "mirror" not in self.magnitudes:
            return x, v
        draw = (self._uniform("mirror", epoch, indices, 1)[:, 0] + 1.0) / 2.0  # [0, 1)
        flip = draw < self.magnitudes["mirror"]
        x, v = np.array(x, copy=True), np.array(v, copy=True)
        sign_x = np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0], dtype=x.dtype)  # gyro x, y, z; acc x, y, z
        x[flip] *= sign_x[None, :, None]
        v[flip, ..., 1] *= -1
        return x, v

    def stretch_strides(
        self, x: np.ndarray, v: np.ndarray, indices: np.ndarray, epoch: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """Windows ``(B, 6, L)`` and targets ``(B, [K,] D)`` with the horizontal motion scaled (module
        docstring). Returns new arrays (the same ones when stride_length is off)."""
        if "stride_length" not in self.magnitudes:
            return x, v
        factors = self._log_uniform("stride_length", epoch, indices)
        x, v = np.array(x, copy=True), np.array(v, copy=True)
        x[:, 3:5, :] *= factors[:, None, None].astype(x.dtype)
        v[..., :2] *= factors.reshape((-1,) + (1,) * (v.ndim - 1)).astype(v.dtype)
        return x, v

    def before_yaw(self, x: np.ndarray, indices: np.ndarray, epoch: int) -> np.ndarray:
        """The motion's own variations (vertical bounce scale)."""
        if "vertical" in self.magnitudes:
            m = self.magnitudes["vertical"]
            factor = 1.0 + m * self._uniform("vertical", epoch, indices, 1)[:, 0]
            x = scale_acc_component(x, np.array([0.0, 0.0, 1.0]), factor)
        return x

    def after_yaw(self, x: np.ndarray, indices: np.ndarray, epoch: int) -> np.ndarray:
        """Errors of the input rotation, then of the sensor (module docstring)."""
        b, _, length = x.shape
        mags = self.magnitudes
        if "orientation" in mags:
            draw = self._uniform("orientation", epoch, indices, 3)  # heading, tilt, tilt axis
            ramp = np.linspace(0.0, 1.0, length)[None, :]  # (1, L)
            heading = np.radians(mags["orientation"] * draw[:, :1]) * ramp  # (B, L)
            tilt = np.radians(0.5 * mags["orientation"] * draw[:, 1:2]) * ramp
            axis = np.pi * draw[:, 2:3]
            rotvec = np.stack([tilt * np.cos(axis), tilt * np.sin(axis), heading], axis=-1)  # (B, L, 3)
            x = rotate_windows(x, Rotation.from_rotvec(rotvec.reshape(-1, 3)), per_sample=True)
        if "tilt" in mags:
            draw = self._uniform("tilt", epoch, indices, 2)
            angle = np.radians(mags["tilt"]) * np.abs(draw[:, 0])
            axis = np.pi * draw[:, 1]
            rotvec = np.stack([angle * np.cos(axis), angle * np.sin(axis), np.zeros(b)], axis=1)
            x = rotate_windows(x, Rotation.from_rotvec(rotvec))
        x = np.array(x, copy=True)
        for name, first in (("gyro_bias", 0), ("acc_bias", 3)):
            if name in mags:
                bias = mags[name] * self._uniform(name, epoch, indices, 3)  # (B, 3)
                x[:, first : first + 3, :] += bias[:, :, None].astype(x.dtype)
        for name, first in (("gyro_noise", 0), ("acc_noise", 3)):
            if name in mags:
                noise = np.stack(
                    [self._rng(name, epoch, i).normal(0.0, mags[name], (3, length)) for i in indices]
                )
                x[:, first : first + 3, :] += noise.astype(x.dtype)
        return x.astype(np.float32, copy=False)
