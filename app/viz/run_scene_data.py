"""What the scene needs from a run, computed once when the run arrives (not on every slider move).

Decisions:
- The timeline runs in seconds from the sequence's first sample, shared by every shown run.
- A prediction's span is the one ``ftin.infer`` reports (``Prediction.span_t_s``): a whole window
  for window models, a 1 s sub-window for RNIN, one frame for RoNIN's LSTM / TCN. Without it (an
  older prediction) the checkpoint's window is placed around ``window_t_s``, the middle of its span.
- The FDL spectra are recomputed for the window on screen from the run's ``ModelInput``
  (``app.services.features``); whether a model has them at all is found once, on window 0.
- How sure the path is (``PathSpread``: its covariance, ``ftin.uncertainty``) is taken once too; a live
  run's only every 10 s of walking (``PathSpread.grown``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from app.services.features import CHANNEL_SPECTRUM, TEMPORAL_SPECTRUM, ModelInput, window_taps
from app.services.runs import Run
from app.viz.palette import RGB
from app.viz.path_spread import PathSpread
from app.viz.spectra import (
    amplitude_spectrum,
    heading_error_per_window,
    interpolate_positions,
    position_error_per_window,
    velocity_error_per_window,
)
from ftin.checkpoint import LoadedModel
from ftin.data import ImuSequence, Trajectory

# Where window_t_s sits inside its window (ftin.infer: the middle of [t[s], t[s + L]]).
WINDOW_T_ANCHOR = 0.5

RAW_CHANNELS = ("gyro x", "gyro y", "gyro z", "acc x", "acc y", "acc z")


@dataclass(frozen=True)
class RunView:
    run_id: str
    model_name: str
    color: RGB
    sequence: ImuSequence
    trajectory: Trajectory
    window_t_s: np.ndarray  # (M,)
    window_start_s: np.ndarray  # (M,)
    window_end_s: np.ndarray  # (M,)
    metrics: dict[str, float | None] | None  # every registered metric by name (ftin.metrics)
    convention: str | None  # how the metrics align the estimate ("ronin": not at all)
    truth: Trajectory | None  # the ground truth in the prediction's frame (what was scored)
    warnings: tuple[str, ...]  # what may be wrong with this run (the path length included)
    position_error_m: np.ndarray | None  # (M,) horizontal, at window times
    velocity_error_m_s: np.ndarray | None  # (M,)
    heading_error_deg: np.ndarray | None  # (M,) walking direction, predicted - true
    loaded: LoadedModel | None  # to recompute feature taps
    model_input: ModelInput | None
    has_spectra: bool  # the model has FDL spectra to show
    alignment: str | None = None  # ftin.metrics.alignment_modes in words, fitted heading (None: no metrics)
    alignment_mode: str | None = None  # none, start, se2 or se3: what the Alignment menu shows for it
    worse_than_still: bool | None = None  # its ATE at or above standing still's (None: no baseline)
    still_text: str | None = None  # the comparison with standing still, in words
    stand_still: dict[str, float | None] | None = None  # the table metrics of never moving
    scope_note: str | None = None  # why ATE means little on this recording, if it does
    plausibility: Any = None  # ftin.metrics.plausibility.Plausibility: figures without ground truth, GPS
    display_name: str = ""  # the model's name people know ("RNIN · OxIOD"); model_name is the API's
    spread: PathSpread | None = None  # the path's covariance (None: no uncertainty for this run)
    filter_series: dict[str, np.ndarray] | None = None  # the EKF's tilt and biases (ftin.filter.choice)

    @classmethod
    def from_run(
        cls, run: Run, color: RGB, window_s: float, loaded: LoadedModel | None = None, display_name: str = ""
    ) -> RunView:
        pred = run.prediction
        t = np.asarray(pred.window_t_s, dtype=np.float64)
        spans = pred.span_t_s
        if spans is not None and len(spans) == len(t):
            start, end = np.asarray(spans[:, 0], dtype=np.float64), np.asarray(spans[:, 1], dtype=np.float64)
        else:
            start = t - WINDOW_T_ANCHOR * window_s
            end = start + window_s
        gt = run.truth
        model_input = run.model_input if loaded is not None and len(t) > 0 else None
        has_spectra = model_input is not None and window_taps(loaded, model_input, 0) is not None
        verdict, scored = run.verdict, run.metrics
        return cls(
            run_id=run.run_id,
            model_name=run.model_name,
            color=color,
            sequence=run.sequence,
            trajectory=pred.trajectory,
            window_t_s=t,
            window_start_s=start,
            window_end_s=end,
            metrics=None if scored is None else dict(scored.values),
            convention=None if scored is None else scored.convention.value,
            truth=gt,
            warnings=tuple(verdict.warnings),
            position_error_m=None if gt is None else position_error_per_window(t, pred.trajectory, gt),
            velocity_error_m_s=(
                None if gt is None else velocity_error_per_window(start, end, pred.velocity_m_s, gt)
            ),
            heading_error_deg=(None if gt is None else heading_error_per_window(t, pred.trajectory, gt)),
            loaded=loaded,
            model_input=model_input,
            has_spectra=has_spectra,
            alignment=_alignment_words(scored),
            alignment_mode=None if scored is None else scored.alignment,
            worse_than_still=None if verdict.still is None else verdict.still.worse_than_standing_still,
            still_text=None if verdict.still is None else verdict.still.text,
            stand_still=verdict.stand_still,
            scope_note=verdict.scope_note,
            plausibility=run.plausibility,
            display_name=display_name,
            spread=PathSpread.of_run(run),
            filter_series=(pred.features or {}).get("filter_series"),
        )

    @property
    def shown_name(self) -> str:
        return self.display_name or self.model_name

    @property
    def t0_s(self) -> float:
        return float(self.sequence.t_s[0])

    @property
    def flags(self) -> list[str]:
        """Why this run is flagged (⚠), in words: worse than standing still, a path off the truth's."""
        return [
            *(["worse than standing still"] if self.worse_than_still else []),
            *(["path"] if self.path_warning else []),
        ]

    @property
    def path_warning(self) -> bool:
        """A warning names the path: the model walks far too little or too much."""
        return any("path" in w for w in self.warnings)

    def grown(self, run: Run) -> RunView:
        """This view of a live run with the arrays of ``run``, the same run grown (views, no copies:
        the same cost at minute 1 and minute 60)."""
        pred = run.prediction
        return replace(
            self,
            sequence=run.sequence,
            trajectory=pred.trajectory,
            window_t_s=pred.window_t_s,
            window_start_s=pred.span_t_s[:, 0],
            window_end_s=pred.span_t_s[:, 1],
            model_input=run.model_input if self.model_input is not None else None,
            warnings=tuple(pred.warnings),
            spread=PathSpread.of_run(run) if self.spread is None else self.spread.grown(run),
        )

    def spectra_at(self, index: int) -> tuple[np.ndarray | None, np.ndarray | None]:
        """FDL ``(channel-axis (C_res // 2 + 1, L_res), temporal-axis (C_res, L_res // 2 + 1))`` |FFT|
        of window ``index``, mean over ``d``; ``(None, None)`` for a model without FDL."""
        if not self.has_spectra:
            return None, None
        taps = window_taps(self.loaded, self.model_input, index) or {}
        return taps.get(CHANNEL_SPECTRUM), taps.get(TEMPORAL_SPECTRUM)

    # Lookups by time bisect the sorted time axes (never scan them): a slider move, or a live walk's
    # update, costs the same at minute 1 and minute 60.

    def window_at(self, t_s: float) -> int:
        """Index of the window whose time stamp is nearest to ``t_s``."""
        t = self.window_t_s
        i = int(np.searchsorted(t, t_s))
        if i == 0 or i == len(t):
            return max(0, min(i, len(t) - 1))
        return i if t[i] - t_s < t_s - t[i - 1] else i - 1

    def position_at(self, t_s: float) -> np.ndarray:
        return positions_near(self.trajectory, np.array([t_s]))[0]

    def window_points(self, index: int, truth: bool = False) -> np.ndarray:
        """Positions along window ``index`` (estimate, or ground truth), at least two points."""
        traj = self.truth if truth else self.trajectory
        assert traj is not None
        t0, t1 = self.window_start_s[index], self.window_end_s[index]
        inside = traj.t_s[np.searchsorted(traj.t_s, t0, side="right") : np.searchsorted(traj.t_s, t1)]
        return positions_near(traj, np.concatenate([[t0], inside, [t1]]))

    def raw_spectrum(self, index: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Amplitude spectra ``(freq_hz, (6, F))`` of the raw device-frame IMU inside window ``index``."""
        seq = self.sequence
        rows = slice(*np.searchsorted(seq.t_s, [self.window_start_s[index], self.window_end_s[index]]))
        if rows.stop - rows.start < 4:
            return None
        samples = np.concatenate([seq.gyro_rad_s[rows], seq.acc_m_s2[rows]], axis=1)
        return amplitude_spectrum(samples, seq.rate_hz)


def positions_near(traj: Trajectory, t_s: np.ndarray) -> np.ndarray:
    """``interpolate_positions`` over only the stretch of ``traj`` that brackets the sorted times ``t_s``."""
    lo = max(int(np.searchsorted(traj.t_s, t_s[0])) - 1, 0)
    hi = int(np.searchsorted(traj.t_s, t_s[-1], side="right")) + 1
    return interpolate_positions(traj.slice(lo, hi), t_s)


def sequence_key(run: Run) -> tuple[Any, ...]:
    """Which recording a run shows; a live session is one recording however far it has grown."""
    if run.source == "live":
        return ("live", run.run_id)
    seq = run.sequence
    return (run.sequence_id or seq.name, len(seq), float(seq.t_s[0]), float(seq.t_s[-1]))


def _alignment_words(metrics: Any) -> str | None:
    """``start (heading +12.3°)``: the alignment the metrics used and what it fitted."""
    if metrics is None or getattr(metrics, "alignment", None) is None:
        return None
    heading = "" if metrics.heading_deg is None else f" (fitted heading {metrics.heading_deg:+.1f}°)"
    return f"{metrics.alignment}{heading}"
