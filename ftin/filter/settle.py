"""Offline, a second pass: the filter run again from where its first pass settled (``docs/filter.md``,
"The second pass").

A causal filter starts from the orientation filter's tilt with zero biases and spends its first 10-20 s
settling: on the validation walks its tilt is 0.8-2.5 deg off over the first 20 s against 0.4-1.4
over the whole walk (``docs/results/probes/ekf_settled.md``). An upload is a whole walk, so the second
pass starts with the first pass's biases (their mean over its second half) and with the tilt the first
pass held ``SETTLE_S`` seconds in, carried back to the start by the bias-corrected gyroscope. The
start's heading is kept: it defines the world. Live sessions never take a second pass (causal).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ftin.data import frames
from ftin.data.gaps import holes_of
from ftin.data.types import ImuSequence
from ftin.filter.session import FilterRun
from ftin.filter.state import FilterConfig, quat_of, so3_exp

SETTLE_S = 30.0  # the first pass's tilt is taken this far in (settled on every validation walk by 20 s)
# What is left of the biases after the first pass (one sigma): a tenth of a phone's turn-on bias
# (FilterConfig's 1e-2 rad/s, 0.2 m/s^2), as the first pass's bias estimates vary over a walk's second half.
SETTLED_GYRO_BIAS_STD_RAD_S = 1.0e-3
SETTLED_ACC_BIAS_STD_M_S2 = 0.03

# run(seq, config, start_biases, index) -> FilterRun: pass ``index`` (0, 1) over seq from its first
# orientation.
Pass = Callable[[ImuSequence, FilterConfig, tuple[np.ndarray, np.ndarray] | None, int], FilterRun]


@dataclass
class SettledStart:
    """Where the second pass starts: orientation ``q_wxyz`` (the carried-back tilt under the start's
    heading; the start as it was where ``carried`` is False) and the ``biases`` (gyro, accelerometer)."""

    q_wxyz: np.ndarray
    biases: tuple[np.ndarray, np.ndarray]
    carried: bool

    def applied_to(self, seq: ImuSequence) -> ImuSequence:
        """``seq`` with its first orientation (the filter's start) replaced."""
        q = np.array(seq.q_world_device_wxyz, dtype=np.float64)
        q[0] = self.q_wxyz
        return seq.with_(q_world_device_wxyz=q)


def settled_start(seq: ImuSequence, first: FilterRun) -> SettledStart:
    """The second pass's start from the ``first`` pass over ``seq`` (module docstring). The tilt is not
    carried back across a hole (its gyroscope is invented) nor from a walk's last sample where the
    walk is shorter than ``SETTLE_S``: there the start keeps its orientation."""
    half = len(first.t_s) // 2
    bg = first.gyro_bias_rad_s[half:].mean(axis=0)
    ba = first.acc_bias_m_s2[half:].mean(axis=0)
    t = seq.t_s
    q_start = np.asarray(seq.q_world_device_wxyz[0], dtype=np.float64)
    holes = holes_of(seq)
    k_settled = int(np.searchsorted(t, t[0] + SETTLE_S))
    if k_settled >= len(t) or (len(holes) and holes[:, 0].min() < t[k_settled]):
        return SettledStart(q_start, (bg, ba), carried=False)
    R = frames.rotation_from_wxyz(first.q_world_device_wxyz[k_settled]).as_matrix()
    w = np.asarray(seq.gyro_rad_s, dtype=np.float64) - bg
    dt = np.diff(t[: k_settled + 1])
    for k in range(k_settled - 1, -1, -1):  # R_k = R_k+1 Exp(-w dt): the filter's midpoint rule undone
        R = R @ so3_exp(-0.5 * (w[k] + w[k + 1]) * dt[k])
    # The carried tilt under the start's heading: the heading is the world's definition, not an estimate.
    return SettledStart(frames.with_heading_of(q_start, quat_of(R)), (bg, ba), carried=True)


def settled_config(config: FilterConfig) -> FilterConfig:
    """``config`` with the start's bias uncertainty of a second pass."""
    return replace(
        config,
        init_gyro_bias_std_rad_s=SETTLED_GYRO_BIAS_STD_RAD_S,
        init_acc_bias_std_m_s2=SETTLED_ACC_BIAS_STD_M_S2,
    )


def two_passes(seq: ImuSequence, config: FilterConfig, run: Pass) -> tuple[FilterRun, SettledStart]:
    """``run`` over ``seq`` once, then again from where it settled: the second run and its start."""
    first = run(seq, config, None, 0)
    start = settled_start(seq, first)
    return run(start.applied_to(seq), settled_config(config), start.biases, 1), start
