"""World-frame IMU windows, velocity targets, input normalisation and the training Dataset.

Decisions (``docs/design.md``, "Frames"):
- Window ``k`` starts at sample ``s = k * stride``; its input is samples ``s .. s + L - 1`` and its
  target is the mean velocity over the same ``L`` sample intervals,
  ``(p[s + L] - p[s]) / (t[s + L] - t[s])``. A window therefore needs sample ``s + L`` and starts run
  while ``s + L <= N - 1``; inference of window models uses the same starts, so a window's velocity
  always belongs to the span ``[t[s], t[s + L]]`` (streaming models run whole recordings instead,
  ``ftin.infer``).
- Parts (``ftin.models.base``): a model may predict the velocity of K equal consecutive parts of
  its window (RNIN: its sub-windows; RoNIN LSTM/TCN: every frame). Part k of the window starting at
  ``s`` spans samples ``a = s + k L/K`` to ``b = a + L/K`` and its target is
  ``(p[b] - p[a]) / (t[b] - t[a])`` (``part_velocity_targets``); K = 1 is exactly the window target
  above. ``WindowDataset`` computes the part targets per batch from the positions (memory O(N), not
  O(windows x K)) and yields them as ``(B, K, D)``.
- Inputs are ``(6, L)`` float32, channels gyro xyz then acc xyz, rotated into the gravity-aligned
  world frame by ``world_imu`` (the sequence must carry an orientation and
  be at the intended rate: ``ensure_orientation`` and ``resample`` come first).
- Windows are strided views of one ``(N, 6)`` array (``sliding_window_view``) or gathered with one
  fancy index per batch; no per-window Python loop.
- Ground truth that a motion-capture system did not measure (``Trajectory.tracked`` False: lost or
  glitching, interpolated by the reader) never becomes a target: training windows with a part bound
  on such a sample are dropped (``measured_starts``); inputs are all real IMU samples either way.
- Yaw augmentation rotates gyro, acc and the targets (every part of a window alike) about world z by
  the same angle, which keeps the physics consistent and makes the network heading-agnostic
  (RoNIN). Angles are drawn per epoch out of
  ``(seed, epoch)``, indexed by window, so a batch's augmentation does not depend on the order
  or the process that draws it: resumed and multi-process runs see the same data.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any, Protocol

import numpy as np
import torch
from numpy.lib.stride_tricks import sliding_window_view
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.gaps import holes_of, starts_outside_holes
from ftin.data.types import ImuSequence

N_CHANNELS = 6  # gyro xyz, acc xyz


class WindowAugmentation(Protocol):
    """What ``WindowDataset`` asks of the training augmentations (``ftin.train.augment.WindowAugmenter``):
    seeded per window index and epoch, so a batch's augmentation depends on neither the batch order
    nor the process that draws it. ``x`` is ``(B, 6, L)``, world frame; falsy: nothing to do."""

    def __bool__(self) -> bool: ...

    def shift_starts(
        self, starts: np.ndarray, lowest: np.ndarray, highest: np.ndarray, indices: np.ndarray, epoch: int
    ) -> np.ndarray: ...

    def pace_factors(
        self, indices: np.ndarray, epoch: int, reach: np.ndarray, window: int
    ) -> np.ndarray | None: ...

    def pace(self, x: np.ndarray, v: np.ndarray, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def mirror(
        self, x: np.ndarray, v: np.ndarray, indices: np.ndarray, epoch: int
    ) -> tuple[np.ndarray, np.ndarray]: ...

    def stretch_strides(
        self, x: np.ndarray, v: np.ndarray, indices: np.ndarray, epoch: int
    ) -> tuple[np.ndarray, np.ndarray]: ...

    def before_yaw(self, x: np.ndarray, indices: np.ndarray, epoch: int) -> np.ndarray: ...

    def after_yaw(self, x: np.ndarray, indices: np.ndarray, epoch: int) -> np.ndarray: ...


@dataclass(frozen=True)
class Windows:
    """The windows of one sequence: inputs, targets and where each window starts."""

    x: np.ndarray  # (M, 6, L) float32, world frame
    v: np.ndarray  # (M, D) float32, world-frame velocity target in m/s
    start: np.ndarray  # (M,) int64 first sample of each window
    window: int
    stride: int

    def __len__(self) -> int:
        return len(self.start)


def window_starts(n_samples: int, window: int, stride: int) -> np.ndarray:
    """First sample of every window of ``window`` samples whose end sample ``s + window`` exists."""
    _check_window_args(window, stride)
    last = n_samples - 1 - window
    if last < 0:
        return np.zeros(0, dtype=np.int64)
    return np.arange(0, last + 1, stride, dtype=np.int64)


def world_imu(seq: ImuSequence, dtype: type = np.float32) -> np.ndarray:
    """``(N, 6)`` gyro xyz then acc xyz rotated by ``q_world_device`` into the gravity-aligned world
    frame (float32, the model's input; ``dtype=np.float64`` for analysis)."""
    if seq.q_world_device_wxyz is None:
        raise DataFormatError(
            f"sequence {seq.name!r} has no orientation (q_world_device_wxyz); call "
            "ftin.data.preprocess.ensure_orientation before making world-frame windows"
        )
    rotation = frames.rotation_from_wxyz(seq.q_world_device_wxyz)
    imu = np.concatenate([rotation.apply(seq.gyro_rad_s), rotation.apply(seq.acc_m_s2)], axis=1)  # (N, 6)
    return imu.astype(dtype)


def window_view(imu: np.ndarray, window: int) -> np.ndarray:
    """Read-only ``(N - window + 1, 6, window)`` view of an ``(N, 6)`` array: window k = rows k.."""
    return sliding_window_view(imu, window, axis=0)  # (N - L + 1, 6, L)


def warp_windows(imu: np.ndarray, starts: np.ndarray, window: int, factors: np.ndarray) -> np.ndarray:
    """``(B, 6, window)`` float32 windows of ``imu (N, 6)``, window b resampled (linear interpolation)
    from the span of ``factors[b] x window`` samples from ``starts[b]``: factor 1 gives the plain
    window, 1.25 a window that holds 1.25 windows' worth of motion. The span must lie inside ``imu``."""
    pos = (
        np.asarray(starts, dtype=np.float64)[:, None]
        + np.arange(window)[None, :] * np.asarray(factors, dtype=np.float64)[:, None]
    )  # (B, L) fractional sample indices
    if len(pos) and pos.max() > len(imu) - 1:
        raise ValueError(f"warped window needs sample {pos.max():.0f}, the data has {len(imu)}")
    low = np.floor(pos).astype(np.int64)
    frac = (pos - low)[:, :, None]
    high = np.minimum(low + 1, len(imu) - 1)
    a, b = imu[low], imu[high]  # (B, L, 6)
    return (a + frac * (b - a)).transpose(0, 2, 1).astype(np.float32)


def velocity_targets(
    t_s: np.ndarray, p_world_m: np.ndarray, starts: np.ndarray, window: int, out_dim: int = 2
) -> np.ndarray:
    """``(M, out_dim)`` float32 mean velocity over each window: ``(p[s+L] - p[s]) / (t[s+L] - t[s])``."""
    return part_velocity_targets(t_s, p_world_m, starts, window, 1, out_dim)[:, 0]


def part_velocity_targets(
    t_s: np.ndarray, p_world_m: np.ndarray, starts: np.ndarray, window: int, parts: int, out_dim: int = 2
) -> np.ndarray:
    """``(M, parts, out_dim)`` float32 mean velocity over each of ``parts`` equal parts of each window.

    Part k of the window at ``s`` spans ``a = s + k * window / parts`` to ``b = a + window / parts``:
    ``(p[b] - p[a]) / (t[b] - t[a])``.
    """
    if out_dim not in (2, 3):
        raise ValueError(f"out_dim must be 2 (horizontal) or 3, got {out_dim}")
    if parts < 1 or window % parts:
        raise ValueError(f"a window of {window} samples cannot be cut into {parts} equal parts")
    bounds = np.asarray(starts)[:, None] + np.arange(parts + 1) * (window // parts)  # (M, K + 1)
    dt = np.diff(t_s[bounds], axis=1)  # (M, K)
    dp = np.diff(p_world_m[bounds, :out_dim], axis=1)  # (M, K, D)
    return (dp / dt[:, :, None]).astype(np.float32)


def measured_starts(
    starts: np.ndarray, tracked: np.ndarray | None, window: int, parts: int = 1
) -> np.ndarray:
    """The window starts whose target is measured: every part bound a tracked ground-truth sample.

    A target only reads positions at its part bounds (``part_velocity_targets``), so a window over an
    untracked stretch still has an exact target when its bounds were tracked; a bound on a sample the
    reader interpolated (``Trajectory.tracked`` False) would make up its target, so that window goes.
    """
    starts = np.asarray(starts, dtype=np.int64)
    if tracked is None or not len(starts):
        return starts
    bounds = starts[:, None] + np.arange(parts + 1) * (window // parts)  # (M, K + 1)
    return starts[np.asarray(tracked, dtype=bool)[bounds].all(axis=1)]


def make_windows(seq: ImuSequence, window: int, stride: int, out_dim: int = 2) -> Windows:
    """World-frame windows of ``seq`` and their velocity targets (needs ground truth); windows whose
    target would read an untracked ground-truth sample are left out (``measured_starts``)."""
    _check_training_sequence(seq, window)
    imu = world_imu(seq)
    starts = measured_starts(window_starts(len(seq), window, stride), seq.gt.tracked, window)
    x = np.ascontiguousarray(window_view(imu, window)[starts])  # (M, 6, L)
    v = velocity_targets(seq.t_s, seq.gt.p_world_m, starts, window, out_dim)
    return Windows(x=x, v=v, start=starts, window=window, stride=stride)


def rotate_yaw(x: np.ndarray, v: np.ndarray, angle_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotate windows ``(B, 6, L)`` and targets ``(B, D)`` or ``(B, K, D)`` about world z by
    ``angle_rad (B,)`` (all K parts of a window by its one angle).

    Returns new arrays (inputs are not modified). Gyro and acc are rotated as 3-vectors; a 2-D
    target is the horizontal part of a 3-vector, which a rotation about z keeps horizontal.
    """
    angles = np.asarray(angle_rad, dtype=np.float64).reshape(-1, 1)  # (B, 1): one axis per rotation
    R = Rotation.from_euler("z", angles).as_matrix()  # (B, 3, 3)
    R = R.astype(x.dtype, copy=False)
    gyro = np.einsum("bij,bjl->bil", R, x[:, 0:3, :])
    acc = np.einsum("bij,bjl->bil", R, x[:, 3:6, :])
    d = v.shape[-1]
    if v.ndim == 3:  # (B, K, D) part targets
        v_rot = np.einsum("bij,bkj->bki", R[:, :d, :d], v).astype(v.dtype, copy=False)
    else:
        v_rot = np.einsum("bij,bj->bi", R[:, :d, :d], v).astype(v.dtype, copy=False)
    return np.concatenate([gyro, acc], axis=1), v_rot


class Normalization(str, Enum):
    """Input normalisation, stored in the checkpoint so inference applies the same one."""

    NONE = "none"  # RoNIN feeds raw world-frame IMU; the models' batch-norm stems absorb the scale
    CHANNEL_STATS = "channel_stats"  # per-channel mean / std of the training data


@dataclass(frozen=True)
class InputNormalization:
    """``x -> (x - mean) / std`` per channel; identity for ``Normalization.NONE``."""

    kind: Normalization = Normalization.NONE
    mean: tuple[float, ...] = (0.0,) * N_CHANNELS
    std: tuple[float, ...] = (1.0,) * N_CHANNELS

    def apply(self, x: torch.Tensor) -> torch.Tensor:
        """Normalise a ``(B, 6, L)`` batch (returns a new tensor; identity returns ``x``)."""
        if self.kind is Normalization.NONE:
            return x
        mean = torch.tensor(self.mean, dtype=x.dtype, device=x.device)[None, :, None]
        std = torch.tensor(self.std, dtype=x.dtype, device=x.device)[None, :, None]
        return (x - mean) / std

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind.value, "mean": list(self.mean), "std": list(self.std)}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> InputNormalization:
        kind = Normalization(data.get("kind", Normalization.NONE.value))
        mean = tuple(float(m) for m in data.get("mean", (0.0,) * N_CHANNELS))
        std = tuple(float(s) for s in data.get("std", (1.0,) * N_CHANNELS))
        if len(mean) != N_CHANNELS or len(std) != N_CHANNELS or min(std) <= 0:
            raise ValueError(f"normalization needs 6 means and 6 positive stds, got {mean} / {std}")
        return cls(kind, mean, std)


def fit_normalization(imu_arrays: Sequence[np.ndarray], kind: Normalization) -> InputNormalization:
    """Statistics over every sample of the training sequences' ``(N, 6)`` world-frame arrays.

    Horizontal axes share one statistic per sensor (mean 0, pooled std) because yaw augmentation
    makes x and y interchangeable; z keeps its own mean (gravity on acc z).
    """
    kind = Normalization(kind)
    if kind is Normalization.NONE:
        return InputNormalization()
    data = np.concatenate([np.asarray(a, dtype=np.float64) for a in imu_arrays], axis=0)
    mean = np.zeros(N_CHANNELS)
    std = np.ones(N_CHANNELS)
    for first in (0, 3):  # gyro, acc
        horizontal = data[:, first : first + 2]
        std[first : first + 2] = np.sqrt(np.mean(horizontal**2))
        mean[first + 2] = data[:, first + 2].mean()
        std[first + 2] = data[:, first + 2].std()
    std = np.maximum(std, 1e-6)  # a constant channel (simulated data) must not divide by zero
    return InputNormalization(kind, tuple(mean.tolist()), tuple(std.tolist()))


class WindowDataset(torch.utils.data.Dataset):
    """Windows of several sequences (already oriented and resampled) with seeded yaw augmentation
    and, with an ``augmenter``, the other training augmentations (``ftin.train.augment``).

    Items are ``(x (6, L), v (K, D))`` float32 tensors, K = ``parts`` (the model's
    ``target_parts(window)``; 1 for window models, whose single part is the window's target);
    ``get_batch(indices)`` builds a whole batch with one gather. Call ``set_epoch`` before each epoch
    to draw that epoch's augmentation angles.
    """

    def __init__(
        self,
        sequences: Sequence[ImuSequence],
        window: int,
        stride: int,
        out_dim: int = 2,
        *,
        parts: int = 1,
        augment_yaw: bool = True,
        seed: int = 0,
        augmenter: WindowAugmentation | None = None,
    ) -> None:
        _check_window_args(window, stride)
        if not sequences:
            raise ValueError("WindowDataset needs at least one sequence")
        if out_dim not in (2, 3):
            raise ValueError(f"out_dim must be 2 (horizontal) or 3, got {out_dim}")
        if parts < 1 or window % parts:
            raise ValueError(f"a window of {window} samples cannot be cut into {parts} equal parts")
        imu_parts, start_parts, t_parts, p_parts, bound_parts = [], [], [], [], []
        reach_parts, tracked_parts = [], []
        offset = 0
        for seq in sequences:
            _check_training_sequence(seq, window)
            imu = world_imu(seq)
            starts = measured_starts(window_starts(len(seq), window, stride), seq.gt.tracked, window, parts)
            starts = starts_outside_holes(seq, starts, window)
            imu_parts.append(imu)
            t_parts.append(np.asarray(seq.t_s, dtype=np.float64))
            p_parts.append(np.asarray(seq.gt.p_world_m[:, :out_dim], dtype=np.float64))
            start_parts.append(starts + offset)
            last = len(seq) - 1 - window  # the last start whose end sample exists
            bound_parts.append(np.broadcast_to([[offset, offset + last]], (len(starts), 2)))
            reach_parts.append(samples_within_reach(seq, starts))
            tracked = seq.gt.tracked
            tracked_parts.append(np.ones(len(seq), bool) if tracked is None else np.asarray(tracked, bool))
            offset += len(seq)
        self.imu = np.concatenate(imu_parts, axis=0)  # (N_total, 6) float32
        self.imu_per_sequence = imu_parts
        self.starts = np.concatenate(start_parts)  # (M,) index into self.imu
        self._start_bounds = np.concatenate(bound_parts)  # (M, 2): a window's sequence, for shifts
        # Ground truth of every sample; a window's part bounds stay inside its own sequence.
        self._t_s = np.concatenate(t_parts)  # (N_total,)
        self._p_world_m = np.concatenate(p_parts, axis=0)  # (N_total, D)
        self._tracked = np.concatenate(tracked_parts)  # (N_total,) bool: a target may read it
        self._reach = np.concatenate(reach_parts)  # (M,) samples a window may span: a pace stretch's limit
        self.parts = parts
        self.window = window
        self.stride = stride
        self.out_dim = out_dim
        self.augment_yaw = augment_yaw
        self.augmenter = augmenter if augmenter else None  # ftin.train.augment; None: yaw only
        self.seed = seed
        self.names = [seq.name for seq in sequences]
        self._angles = np.zeros(len(self.starts))
        self.set_epoch(0)

    def set_epoch(self, epoch: int) -> None:
        """Draw this epoch's yaw angle for every window (deterministic from seed and epoch)."""
        self.epoch = epoch
        if self.augment_yaw:
            rng = np.random.default_rng([self.seed, epoch])
            self._angles = rng.uniform(-np.pi, np.pi, size=len(self.starts))

    def __len__(self) -> int:
        return len(self.starts)

    def targets(self, indices: Sequence[int] | np.ndarray) -> np.ndarray:
        """``(B, K, D)`` float32 part velocity targets of window indices (before augmentation)."""
        return self._targets_at(self.starts[np.asarray(indices, dtype=np.int64)])

    def _part_bounds(self, starts: np.ndarray, factors: np.ndarray) -> np.ndarray:
        """``(B, K + 1)`` fractional sample indices of the part bounds of spans of factor x window."""
        step = (self.window // self.parts) * np.asarray(factors, dtype=np.float64)[:, None]
        return starts[:, None] + np.arange(self.parts + 1)[None, :] * step

    def _targets_at(self, starts: np.ndarray, factors: np.ndarray | None = None) -> np.ndarray:
        if factors is None:
            return part_velocity_targets(
                self._t_s, self._p_world_m, starts, self.window, self.parts, self.out_dim
            )
        # a stretched span: positions and times interpolated at its part bounds
        bounds = self._part_bounds(starts, factors)
        low = np.floor(bounds).astype(np.int64)
        high = np.minimum(low + 1, len(self._t_s) - 1)
        frac = bounds - low
        t = self._t_s[low] + frac * (self._t_s[high] - self._t_s[low])
        p = self._p_world_m[low] + frac[:, :, None] * (self._p_world_m[high] - self._p_world_m[low])
        return (np.diff(p, axis=1) / np.diff(t, axis=1)[:, :, None]).astype(np.float32)

    def _pace_factors(self, indices: np.ndarray, starts: np.ndarray) -> np.ndarray | None:
        """The pace augmentation's stretch of each window (None: off); 1 where the stretched target
        would read an untracked ground-truth sample."""
        reach = self._reach[indices] - (starts - self.starts[indices])  # after a shift
        factors = self.augmenter.pace_factors(indices, self.epoch, reach, self.window)
        if factors is None:
            return None
        low = np.floor(self._part_bounds(starts, factors)).astype(np.int64)
        high = np.minimum(low + 1, len(self._tracked) - 1)
        measured = (self._tracked[low] & self._tracked[high]).all(axis=1)
        return np.where(measured, factors, 1.0)

    def get_batch(self, indices: Sequence[int] | np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        """``(x (B, 6, L), v (B, K, D))`` float32 tensors for window indices."""
        indices = np.asarray(indices, dtype=np.int64)
        starts, aug = self.starts[indices], self.augmenter
        if aug is not None:
            bounds = self._start_bounds[indices]
            starts = aug.shift_starts(starts, bounds[:, 0], bounds[:, 1], indices, self.epoch)
        factors = self._pace_factors(indices, starts) if aug is not None else None
        if factors is None:
            rows = starts[:, None] + np.arange(self.window)[None, :]  # (B, L)
            x = self.imu[rows].transpose(0, 2, 1)  # (B, 6, L)
            v = self._targets_at(starts)
        else:
            x, v = aug.pace(
                warp_windows(self.imu, starts, self.window, factors),
                self._targets_at(starts, factors),
                factors,
            )
        if aug is not None:
            x, v = aug.mirror(x, v, indices, self.epoch)
            x, v = aug.stretch_strides(x, v, indices, self.epoch)
            x = aug.before_yaw(x, indices, self.epoch)
        if self.augment_yaw:
            x, v = rotate_yaw(x, v, self._angles[indices])
        if aug is not None:
            x = aug.after_yaw(x, indices, self.epoch)
        return torch.from_numpy(np.ascontiguousarray(x)), torch.from_numpy(np.ascontiguousarray(v))

    def __getitem__(self, index: int) -> tuple[torch.Tensor, torch.Tensor]:
        x, v = self.get_batch([index])
        return x[0], v[0]


def samples_within_reach(seq: ImuSequence, starts: np.ndarray) -> np.ndarray:
    """``(M,)`` how many samples follow each start before the sequence ends or a held hole begins: the
    longest span a window from there may read (a window stretched by the pace augmentation)."""
    limit = np.full(len(starts), len(seq) - 1, dtype=np.int64)
    t = seq.t_s
    for hole_start, hole_end in holes_of(seq):
        ahead = t[starts] < hole_end  # the window itself never touches a hole: this one lies ahead
        limit[ahead] = np.minimum(limit[ahead], np.searchsorted(t, hole_start, side="right") - 1)
    return limit - np.asarray(starts, dtype=np.int64)


def _check_window_args(window: int, stride: int) -> None:
    if int(window) != window or window < 1:
        raise ValueError(f"window must be a positive number of samples, got {window}")
    if int(stride) != stride or stride < 1:
        raise ValueError(f"stride must be a positive number of samples, got {stride}")


def _check_training_sequence(seq: ImuSequence, window: int) -> None:
    if seq.gt is None:
        raise DataFormatError(
            f"sequence {seq.name!r} has no ground truth; training windows need positions for their "
            "velocity targets"
        )
    if len(seq) < window + 1:
        raise DataFormatError(
            f"sequence {seq.name!r} has {len(seq)} samples, fewer than one window of {window} samples "
            "plus its end sample"
        )
