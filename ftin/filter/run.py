"""The network inside the EKF: one recording through ``ErrorStateEkf``, causally, with a window
model's mean velocity as the measurement (``docs/filter.md``).

``run_filter`` feeds the whole recording to a ``FilterSession`` (``ftin.filter.session``: the one
stepping core, per sample: propagate to k, the update of any window ending at k, the outputs at k,
a clone where a window starts, row k of the network's input), so the estimate at a time never
depends on a later sample, and a live stream fed in chunks gets the same estimates.

``filter_prediction`` wraps it as inference does (``ftin.infer.predict_trajectory``): the same
preparation, a ``Prediction`` whose trajectory is the filter's (positions at every sample, its
orientation), beside the ``FilterRun`` with biases, covariances and the NIS of every update.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from vqf import VQF

from ftin.checkpoint import LoadedModel
from ftin.data import frames
from ftin.data.gaps import holes_of
from ftin.data.orientation_option import choice_of
from ftin.data.prepare import prepare
from ftin.data.types import ImuSequence, Trajectory
from ftin.filter.holes import run_around_holes
from ftin.filter.session import FilterRun, FilterSession
from ftin.filter.settle import SETTLE_S, two_passes
from ftin.filter.state import FilterConfig
from ftin.infer import FRAME_DEVICE_WORLD, FRAME_GROUND_TRUTH, Prediction, run_windows
from ftin.uncertainty.calibration import calibration_for
from ftin.uncertainty.propagate import window_sigma
from ftin.yaw_average import YAW_COPIES


def measurement_source(choice: str, has_head: bool, name: str) -> str:
    """What ``FilterConfig.measurement_sigma`` means for a model: ``auto`` is its head where it has one,
    else ``fixed``; ``head`` on a model without one is a ``ValueError``."""
    if choice == "auto":
        return "head" if has_head else "fixed"
    if choice == "head" and not has_head:
        raise ValueError(f"measurement_sigma 'head': {name!r} has no variance head")
    return choice


class NetworkVelocity:
    """A window model as the filter calls it: one window of world-frame rows in, its mean velocity
    ``(3,)`` (z = 0 for a 2-D model) and the covariance ``(3, 3)`` of its horizontal part out."""

    def __init__(self, loaded: LoadedModel, config: FilterConfig) -> None:
        if loaded.model.streams:
            raise ValueError(f"{loaded.name!r} is a streaming model: the EKF needs a window model")
        self.loaded, self.config = loaded, config
        # One window at a time, so no cycling through the turns across windows: the four copies.
        self.copies = YAW_COPIES
        self.parts = loaded.model.target_parts(loaded.window)
        self.has_head = bool(getattr(loaded.model, "has_uncertainty", False))
        self.sigma_source = measurement_source(config.measurement_sigma, self.has_head, loaded.name)
        self.calibration = None
        self.head_scale = config.measurement_sigma_scale
        if self.sigma_source in ("calibrated", "head"):
            self.calibration = calibration_for(loaded.name)
            if self.sigma_source == "head":
                self.head_scale *= self.calibration.log_std_scale or 1.0  # none fitted: the head as it is

    def __call__(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        window = len(rows)
        velocity, taps = run_windows(
            self.loaded,
            rows,
            np.zeros(1, dtype=np.int64),
            window,
            self.parts,
            1,
            None,
            self.has_head,
            self.copies,
            "fp32",
        )
        v = velocity[0].mean(axis=0)  # (D,): the window's mean over its parts
        out = np.zeros(3)
        out[: min(3, len(v))] = v[:3]
        var = np.full(2, self.config.velocity_std_m_s**2)
        if self.sigma_source == "calibrated":
            # The calibrated per-window sigma (a + b|v|), the one the position uncertainty uses.
            sigma = window_sigma(out[None, :2], self.calibration)[0] * self.config.measurement_sigma_scale
            var = np.full(2, sigma**2)
        elif self.sigma_source == "head":
            # The head's per-axis variance (over K parts the mean's variance is their mean / K), scaled
            # as the position uncertainty scales it.
            part_var = np.exp(2.0 * taps["log_std"].astype(np.float64)[0].reshape(self.parts, -1))
            var = part_var.mean(axis=0)[:2] / self.parts * self.head_scale**2
        return out, np.diag(var)


def run_filter(
    network: NetworkVelocity | None,
    seq: ImuSequence,
    window: int,
    config: FilterConfig | None = None,
    *,
    start_position_m: np.ndarray | None = None,
    start_biases: tuple[np.ndarray, np.ndarray] | None = None,
    measure=None,
    heading_ref_rad: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> FilterRun:
    """The filter over ``seq`` (oriented: its first orientation is the start; on a uniform grid).

    ``measure(rows, start, end, R_start) -> (velocity (3,), covariance (2, 2))`` replaces the network
    where given (tests feed the truth through it; ``R_start`` is the filter's orientation the window's
    first row was built with, whose heading is the measurement's world); otherwise ``network``
    measures each window. ``start_biases``: gyro and accelerometer biases to start from (zero; every
    stretch between holes starts from them). ``heading_ref_rad`` ``(N,)``: a causal heading reference
    in the start's world (``reference_heading``), taken at every update when
    ``config.heading_std_rad`` is set. ``progress(done, total)`` is called after every network update
    (in samples), as inference calls it between batches (a server checks its deadline there). A
    recording with held holes gets one filter per stretch between them (``ftin.filter.holes``).
    """
    config = config or FilterConfig()
    if seq.q_world_device_wxyz is None:
        raise ValueError(f"{seq.name!r} has no orientation to start the filter from")
    n = len(seq)
    if n < window + 1:
        raise ValueError(
            f"{seq.name!r} is too short for the filter: {n} samples, a window needs {window + 1}"
        )

    def run_stretch(piece: ImuSequence, position, heading, offset: int) -> FilterRun:
        session = FilterSession(
            network,
            window,
            config,
            start_q_wxyz=piece.q_world_device_wxyz[0],
            start_position_m=position,
            start_biases=start_biases,
            measure=measure,
            on_update=None if progress is None else (lambda k: progress(offset + k, n)),
        )
        session.update(piece.t_s, piece.gyro_rad_s, piece.acc_m_s2, heading)
        return session.result()

    if len(holes_of(seq)):  # never one filter across invented samples (ftin.filter.holes)
        start = np.zeros(3) if start_position_m is None else start_position_m
        return run_around_holes(seq, window, start, heading_ref_rad, run_stretch)
    return run_stretch(seq, start_position_m, heading_ref_rad, 0)


def reference_heading(seq: ImuSequence, causal: bool = False) -> np.ndarray | None:
    """``(N,)`` a heading reference in the world of ``seq``'s orientation, or None for the ground truth.

    Offline (the default): the heading of ``seq``'s own orientation, what the network reads without
    the filter. ``auto``'s VQF runs offline (forwards and backwards), so its heading at a time knows
    the future; ``causal`` takes VQF run forwards only (``vqf.VQF``) instead, 9-D where ``auto`` chose
    the magnetometer, else 6-D, turned to start at the start orientation's heading. A phone's own
    attitude (``device``) is causal already and is its own reference either way."""
    choice = (seq.meta.get("orientation_choice") or {}).get("source")
    source = seq.meta.get("orientation_source")
    if source == "ground_truth" or choice == "ground_truth":
        return None
    own = frames.yaw_rad(seq.q_world_device_wxyz)
    if not causal or choice == "device" or (choice is None and source == "device"):
        return np.unwrap(own)
    if choice not in ("vqf", "vqf6d"):
        return None
    online = VQF(float(np.median(np.diff(seq.t_s))))
    gyr = np.ascontiguousarray(seq.gyro_rad_s)
    acc = np.ascontiguousarray(seq.acc_m_s2)
    use_mag = choice == "vqf" and seq.mag_uT is not None and np.isfinite(seq.mag_uT).all()
    if use_mag:
        q = online.updateBatch(gyr, acc, np.ascontiguousarray(seq.mag_uT))["quat9D"]
    else:
        q = online.updateBatch(gyr, acc)["quat6D"]
    psi = np.unwrap(frames.yaw_rad(np.asarray(q, dtype=np.float64)))
    return psi - psi[0] + own[0]


def filter_prediction(
    loaded: LoadedModel,
    seq: ImuSequence,
    config: FilterConfig | None = None,
    orientation: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    passes: int = 1,
) -> tuple[Prediction, FilterRun]:
    """``seq`` prepared as inference prepares it (``orientation``: its choice; the filter starts from
    that orientation's first sample), run through the filter with ``loaded`` as its measurement; the
    ``Prediction`` carries the filter's trajectory and orientation for scoring. ``passes=2``: offline,
    the filter again from where its first pass settled (``ftin.filter.settle``); the second's run."""
    if passes not in (1, 2):
        raise ValueError(f"the filter runs in 1 or 2 passes, not {passes!r}")
    config = config or FilterConfig()
    prepared = prepare(seq, loaded.imu_rate_hz, loaded.window, loaded.stride, orientation)
    pseq = prepared.seq
    gt = pseq.gt
    start = gt.p_world_m[0] if gt is not None else np.zeros(3)
    causal = config.heading_reference == "causal"
    heading = reference_heading(pseq, causal) if config.heading_std_rad is not None else None
    network = NetworkVelocity(loaded, config)

    def one_pass(piece: ImuSequence, cfg: FilterConfig, biases, index: int) -> FilterRun:
        # progress over every pass: samples done out of passes x the recording's
        done = index * len(pseq)
        on_update = None if progress is None else (lambda k, n: progress(done + k, passes * n))
        return run_filter(
            network,
            piece,
            loaded.window,
            cfg,
            start_position_m=start,
            start_biases=biases,
            heading_ref_rad=heading,
            progress=on_update,
        )

    notes = ["trajectory and orientation from the EKF"]
    if passes == 1:
        run = one_pass(pseq, config, None, 0)
    else:
        run, settled = two_passes(pseq, config, one_pass)
        carried = f"its tilt at {SETTLE_S:g} s carried back" if settled.carried else "its start"
        notes.append(f"a second pass from the first's biases and {carried} (docs/filter.md)")
    p = run.p_world_m.copy()
    if loaded.out_dim < 3:
        p[:, 2] = start[2]  # as inference does for a 2-D model: the height is not estimated
    spans = run.update_span
    t = run.t_s
    prediction = Prediction(
        trajectory=Trajectory(t.copy(), p, run.q_world_device_wxyz),
        window_t_s=0.5 * (t[spans[:, 0]] + t[spans[:, 1]]),
        velocity_m_s=run.velocity_m_s[:, : loaded.out_dim],
        orientation_source=str(pseq.meta.get("orientation_source", "device")),
        frame=FRAME_GROUND_TRUTH if gt is not None else FRAME_DEVICE_WORLD,
        warnings=list(pseq.meta.get("warnings", [])),
        features=None,
        span_t_s=np.column_stack([t[spans[:, 0]], t[spans[:, 1]]]),
        prepared=prepared,
        truth=gt,
        truth_frame=pseq.meta.get("gt_frame"),
        window_s=loaded.window / float(loaded.imu_rate_hz),
        orientation_filter="ekf",
        imu_world=run.imu_world,
        starts=spans[:, 0].copy(),
        notes=[*pseq.meta.get("notes", []), *prepared.notes, *notes],
        orientation_choice=choice_of(pseq),
    )
    return prediction, run
