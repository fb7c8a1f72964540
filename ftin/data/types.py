"""The sequence and trajectory types that flow through every layer (``docs/design.md``, "The flow of data").

Frames and units live in the field names: ``_s`` seconds, ``_m`` metres, ``_rad_s`` rad/s,
``_m_s2`` m/s². Quaternions are scalar-first ``wxyz`` everywhere (viser's order); convert to
scipy's ``xyzw`` only at the call site (``ftin.data.frames``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np


def _as_float_array(name: str, value: Any, shape_tail: tuple[int, ...]) -> np.ndarray:
    array = np.asarray(value, dtype=np.float64)
    if array.ndim != 1 + len(shape_tail) or array.shape[1:] != shape_tail:
        expected = "(N" + "".join(f", {n}" for n in shape_tail) + ")"
        raise ValueError(f"{name} must have shape {expected}, got {array.shape}")
    return array


@dataclass(frozen=True)
class Trajectory:
    """Positions (and optionally body orientations) over time in one world frame.

    ``tracked`` (optional, bool) is False where a motion-capture system lost the body (or returned a
    glitch) and the reader interpolated the pose: such samples must not become training targets.
    ``None`` means every sample was measured.
    """

    t_s: np.ndarray  # (N,) monotonic seconds
    p_world_m: np.ndarray  # (N, 3)
    q_world_body_wxyz: np.ndarray | None = None  # (N, 4)
    tracked: np.ndarray | None = None  # (N,) bool

    def __post_init__(self) -> None:
        object.__setattr__(self, "t_s", _as_float_array("t_s", self.t_s, ()))
        object.__setattr__(self, "p_world_m", _as_float_array("p_world_m", self.p_world_m, (3,)))
        n = len(self.t_s)
        if len(self.p_world_m) != n:
            raise ValueError(f"p_world_m has {len(self.p_world_m)} rows, t_s has {n}")
        if self.q_world_body_wxyz is not None:
            q = _as_float_array("q_world_body_wxyz", self.q_world_body_wxyz, (4,))
            if len(q) != n:
                raise ValueError(f"q_world_body_wxyz has {len(q)} rows, t_s has {n}")
            object.__setattr__(self, "q_world_body_wxyz", q)
        if self.tracked is not None:
            tracked = np.asarray(self.tracked, dtype=bool)
            if tracked.shape != (n,):
                raise ValueError(f"tracked must have shape ({n},), got {tracked.shape}")
            object.__setattr__(self, "tracked", tracked)

    def __len__(self) -> int:
        return len(self.t_s)

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0]) if len(self) else 0.0

    @property
    def tracked_mask(self) -> np.ndarray:
        """``(N,)`` bool: ``tracked``, or all True when every sample was measured."""
        return np.ones(len(self), dtype=bool) if self.tracked is None else self.tracked

    @property
    def path_length_m(self) -> float:
        return float(np.linalg.norm(np.diff(self.p_world_m, axis=0), axis=1).sum())

    def slice(self, start: int, stop: int) -> Trajectory:
        q = None if self.q_world_body_wxyz is None else self.q_world_body_wxyz[start:stop]
        tracked = None if self.tracked is None else self.tracked[start:stop]
        return Trajectory(self.t_s[start:stop], self.p_world_m[start:stop], q, tracked)


@dataclass(frozen=True)
class Waypoints:
    """Sparse ground truth: where the walker was marked at a few instants, in a map's plane.

    A surveyor's marks (ILC: every ~6 m), not a tracked path: between two marks nothing is known
    (taken to be straight), and the map frame's heading and origin are unrelated to the device's
    world, so scoring fits one 2-D rotation and translation per walk (``ftin.metrics.waypoints``).
    Never interpolated into a dense ``Trajectory``: a path made up between marks is not truth.
    """

    t_s: np.ndarray  # (K,) increasing seconds, on the IMU's clock
    xy_map_m: np.ndarray  # (K, 2) metres in the map frame (x, y); no height

    def __post_init__(self) -> None:
        object.__setattr__(self, "t_s", _as_float_array("t_s", self.t_s, ()))
        object.__setattr__(self, "xy_map_m", _as_float_array("xy_map_m", self.xy_map_m, (2,)))
        if len(self.xy_map_m) != len(self.t_s):
            raise ValueError(f"xy_map_m has {len(self.xy_map_m)} rows, t_s has {len(self.t_s)}")
        if len(self.t_s) > 1 and not np.all(np.diff(self.t_s) > 0):
            raise ValueError("waypoint times must increase")

    def __len__(self) -> int:
        return len(self.t_s)

    @property
    def segment_lengths_m(self) -> np.ndarray:
        """``(K-1,)`` straight distances between consecutive marks."""
        return np.linalg.norm(np.diff(self.xy_map_m, axis=0), axis=1)

    @property
    def path_length_m(self) -> float:
        """Length of the polyline through the marks."""
        return float(self.segment_lengths_m.sum())

    def within(self, t0_s: float, t1_s: float) -> Waypoints:
        """The marks whose time lies in ``[t0_s, t1_s]``."""
        keep = (self.t_s >= t0_s) & (self.t_s <= t1_s)
        return Waypoints(self.t_s[keep], self.xy_map_m[keep])


@dataclass(frozen=True)
class ImuSequence:
    """One IMU recording in the device frame, with optional orientation and ground truth.

    ``acc_m_s2`` is specific force including gravity: +9.81 on the axis pointing up when the device
    lies still. ``q_world_device_wxyz`` rotates device-frame vectors into a gravity-aligned world
    frame (z up, arbitrary yaw). ``gt`` is sampled at ``t_s`` (same N) and lives in the ground-truth
    world frame, which the reader has already aligned with the device world frame at the start.

    ``mag_uT`` (optional) is the calibrated magnetometer in the device frame, on the same clock: the
    orientation filter's heading reference (``ftin.data.preprocess``).

    ``waypoints`` (optional) is sparse truth (:class:`Waypoints`) for a recording with no dense path:
    then ``gt`` is None and ``meta["gt_kind"]`` is ``"waypoints"`` (dense truth: ``"path"`` or absent).
    Waypoints live on the same clock but in a map frame of their own; resampling leaves them as they are.

    ``meta`` keys in use: ``dataset`` (format name), ``source`` (path), ``carry`` (handheld, pocket,
    trolley, ...), ``orientation_source`` ("device", "ground_truth", "estimated"), ``warnings``.
    """

    name: str
    t_s: np.ndarray  # (N,)
    gyro_rad_s: np.ndarray  # (N, 3) device frame
    acc_m_s2: np.ndarray  # (N, 3) device frame, specific force incl. gravity
    q_world_device_wxyz: np.ndarray | None = None  # (N, 4)
    gt: Trajectory | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    mag_uT: np.ndarray | None = None  # (N, 3) device frame, calibrated
    waypoints: Waypoints | None = None  # sparse truth in a map frame (no dense ``gt``)

    def __post_init__(self) -> None:
        object.__setattr__(self, "t_s", _as_float_array("t_s", self.t_s, ()))
        n = len(self.t_s)
        for name in ("gyro_rad_s", "acc_m_s2", "mag_uT"):
            if getattr(self, name) is None:
                continue  # only the magnetometer is optional
            array = _as_float_array(name, getattr(self, name), (3,))
            if len(array) != n:
                raise ValueError(f"{name} has {len(array)} rows, t_s has {n}")
            object.__setattr__(self, name, array)
        if self.q_world_device_wxyz is not None:
            q = _as_float_array("q_world_device_wxyz", self.q_world_device_wxyz, (4,))
            if len(q) != n:
                raise ValueError(f"q_world_device_wxyz has {len(q)} rows, t_s has {n}")
            object.__setattr__(self, "q_world_device_wxyz", q)
        if self.gt is not None and len(self.gt) != n:
            raise ValueError(f"ground truth has {len(self.gt)} samples, IMU has {n}")

    def __len__(self) -> int:
        return len(self.t_s)

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0]) if len(self) > 1 else 0.0

    @property
    def rate_hz(self) -> float:
        """Mean sample rate, from the median interval (robust to a dropped sample)."""
        if len(self) < 2:
            return 0.0
        return float(1.0 / np.median(np.diff(self.t_s)))

    def with_(self, **changes: Any) -> ImuSequence:
        """A copy with some fields replaced (the type is immutable)."""
        return replace(self, **changes)

    def slice(self, start: int, stop: int) -> ImuSequence:
        q = None if self.q_world_device_wxyz is None else self.q_world_device_wxyz[start:stop]
        gt = None if self.gt is None else self.gt.slice(start, stop)
        mag = None if self.mag_uT is None else self.mag_uT[start:stop]
        t_s = self.t_s[start:stop]
        waypoints = None
        if self.waypoints is not None and len(t_s):
            waypoints = self.waypoints.within(float(t_s[0]), float(t_s[-1]))
        return ImuSequence(
            self.name,
            t_s,
            self.gyro_rad_s[start:stop],
            self.acc_m_s2[start:stop],
            q,
            gt,
            dict(self.meta),
            mag,
            waypoints,
        )
