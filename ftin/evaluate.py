"""Evaluate a checkpoint on sequences with ground truth: every registered metric per sequence and mean.

Each sequence goes through exactly the inference path users get (``ftin.infer``), and the metrics
follow one stated convention (``ftin.metrics``, RoNIN's by default). The mean weighs every sequence
equally, as the paper's tables do. Beside every result stands the predictor that never moves
(``ftin.metrics.stand_still``, scored on the same ground truth under the same convention): in a
motion-capture room it scores an ATE of metres, so a model is judged by how far below it gets; and
every result carries its path-length ratio (predicted / true horizontal path) and its heading error over
10-s windows (``ftin.metrics.heading``: the series, its median and its median after minute 2).

``score(prediction)`` is the one scoring step (evo's ``ape(traj_ref, traj_est)``: outside the
estimator): the CLI, the evaluation, the report and the app call it on what inference returned.
It compares the trajectory with the prepared ground truth (``Prediction.truth``) under the rules
of ``ftin.metrics.alignment_modes``: the given alignment, else, under RoNIN's convention, the sequence's
default (``start`` where the ground truth may be in another world frame, else ``none``); an
alignment that cannot be fitted falls back to the unaligned metrics with a warning, and a ground
truth that cannot be scored at all (one that never moves has no drift ratio) gives no metrics and a warning.
A ground truth whose heading is its own (``gt_frame`` "unknown": a recording without orientation) is
aligned at the start by default; scored without alignment (``none`` asked for), a warning says so.
The result stands beside the prediction (``Scored``), which it never changes, as evo's ``ape()``
returns a result and leaves the reference alone. Path lengths are compared over the model's window
(``ftin.metrics.definitions``).

``filter="ekf"`` (``ftin.filter.choice``) scores the model with the EKF instead of alone: the model
re-read on the filter's orientation (``ftin.filter.levelled``), as an upload's answer. With either, where
the ground truth carries an orientation (motion capture), each sequence's mean **tilt error** of the
orientation the answer used (the attitude filter's or the EKF's) against it, in degrees.

Beside the metrics, each sequence's uncertainty coverage (``ftin.uncertainty.coverage``): the share of
samples whose true position lies inside the 1- and 2-sigma ellipse of the path's covariance
(``ftin.uncertainty``, start-aligned) and whether the true end lies within ``end_radius_95_m``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from ftin.checkpoint import LoadedModel
from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence, Trajectory
from ftin.filter.choice import EKF, NONE, ekf_prediction, parse_filter
from ftin.filter.consistency import tilt_error_deg
from ftin.infer import Prediction, predict_trajectory
from ftin.metrics import (
    Alignment,
    AlignmentFit,
    Convention,
    TrajectoryMetrics,
    convention_for,
    default_alignment,
    describe,
    evaluate_aligned,
    evaluate_trajectory,
    list_metrics,
    mean_metrics,
    stand_still,
)
from ftin.metrics.alignment_modes import GT_FRAME_UNKNOWN
from ftin.metrics.heading import HeadingError, heading_error_of
from ftin.uncertainty import path_uncertainty
from ftin.uncertainty.coverage import Coverage, CoverageSummary, coverage_of, pooled


@dataclass(frozen=True)
class SequenceResult:
    name: str
    metrics: TrajectoryMetrics
    duration_s: float
    warnings: list[str] = field(default_factory=list)
    stand_still: TrajectoryMetrics | None = None  # the predictor that never moves, same ground truth
    orientation_choice: dict[str, str] | None = (
        None  # requested, source, reason (ftin.data.orientation_option)
    )
    coverage: Coverage | None = None  # how well the path's uncertainty holds the truth (None: no uncertainty)
    tilt_error_deg: float | None = None  # mean, against the ground truth's orientation (None: it has none)
    heading_error: HeadingError | None = (
        None  # over 10-s windows, start-aligned as scored (ftin.metrics.heading)
    )


def _values(m: TrajectoryMetrics | None) -> dict[str, Any] | None:
    """Every registered metric by name, and the alignment and fitted heading where one was fitted."""
    if m is None:
        return None
    values: dict[str, Any] = dict(m.values)
    if m.alignment is not None:  # ftin.metrics.alignment_modes: which alignment, and the fitted heading
        values.update(alignment=m.alignment, heading_deg=m.heading_deg)
    return values


@dataclass(frozen=True)
class EvaluationReport:
    checkpoint: str
    convention: Convention
    rte_window_s: float
    sequences: list[SequenceResult]
    mean: TrajectoryMetrics
    stand_still: TrajectoryMetrics | None = None  # mean of the sequences' stand-still metrics
    filter: str = NONE  # the model alone (none) or inside the EKF (ekf)

    @property
    def tilt_error_deg(self) -> float | None:
        """The sequences' mean tilt error, over those whose ground truth has an orientation."""
        tilts = [r.tilt_error_deg for r in self.sequences if r.tilt_error_deg is not None]
        return sum(tilts) / len(tilts) if tilts else None

    def describe(self) -> str:
        """The sentence stating the convention, for every table of these numbers."""
        return describe(self.convention, self.rte_window_s)

    @property
    def coverage(self) -> CoverageSummary | None:
        """Every sequence's uncertainty coverage pooled (from the sequences, so a merged report has it)."""
        return pooled([r.coverage for r in self.sequences])

    def to_json(self) -> dict[str, Any]:
        return {
            "checkpoint": self.checkpoint,
            "sequences": [
                {
                    "name": r.name,
                    **_values(r.metrics),
                    "duration_s": r.duration_s,
                    "stand_still": _values(r.stand_still),
                    "orientation_choice": r.orientation_choice,
                    "uncertainty_coverage": None if r.coverage is None else r.coverage.to_json(),
                    "tilt_error_deg": r.tilt_error_deg,
                    "heading_error": None if r.heading_error is None else r.heading_error.to_json(),
                }
                for r in self.sequences
            ],
            "filter": self.filter,
            "tilt_error_deg": self.tilt_error_deg,
            "uncertainty_coverage": None if self.coverage is None else self.coverage.to_json(),
            "mean": _values(self.mean),
            "stand_still": _values(self.stand_still),
            "convention": self.convention.value,
            "rte_window_s": self.rte_window_s,
            "description": self.describe(),
            "metrics": [m.as_dict() for m in list_metrics()],
        }


UNALIGNED_TRUTH = (
    "the ground truth's heading is not aligned with the prediction's (the recording had no orientation "
    "to relate them, and no alignment was asked for): the errors include that turn"
)


@dataclass(frozen=True)
class Scored:
    """What ``score`` found, beside the prediction it scored (which it never changes): the metrics
    (None when the ground truth cannot be scored), the fitted alignment (None when none was fitted),
    the standing-still baseline under the same convention, and warnings for the result."""

    metrics: TrajectoryMetrics | None
    fit: AlignmentFit | None
    warnings: list[str] = field(default_factory=list)
    stand_still: TrajectoryMetrics | None = None

    def truth_in_estimate_frame(self, truth: Trajectory) -> Trajectory:
        """``truth`` drawn where the prediction was scored against it: moved by the inverse of the
        fitted alignment (as given when nothing was fitted). ``truth`` itself is not changed."""
        if self.fit is None or self.fit.alignment is Alignment.NONE:
            return truth
        return self.fit.gt_in_estimate_frame(truth)


def score(
    prediction: Prediction,
    alignment: Alignment | str | None = None,
    convention: Convention = Convention.RONIN,
    rte_window_s: float = 60.0,
    *,
    default_alignment_rule: bool = True,
) -> Scored | None:
    """The prediction's trajectory scored against its prepared ground truth (module docstring); None
    without ground truth. ``alignment`` sets the convention it implies; ``default_alignment_rule=False``
    scores without alignment when none is given (the report's raw tables)."""
    gt = prediction.truth
    if gt is None:
        return None
    trajectory, smooth_s = prediction.trajectory, prediction.window_s
    if alignment is not None:
        convention = convention_for(alignment)
    convention = Convention(convention)
    chosen = None if alignment is None else Alignment(alignment)
    if chosen is None and convention is Convention.RONIN and default_alignment_rule:
        chosen = default_alignment(prediction.truth_frame)
    still = _stand_still(gt, convention, rte_window_s, smooth_s)
    warnings: list[str] = []
    unaligned = chosen is Alignment.NONE or (chosen is None and convention is Convention.RONIN)
    if prediction.truth_frame == GT_FRAME_UNKNOWN and unaligned:
        warnings.append(UNALIGNED_TRUTH)  # its heading is not the prediction's: the errors hold that turn
    if chosen is not None:
        try:
            metrics, fit = evaluate_aligned(trajectory, gt, chosen, rte_window_s, smooth_s=smooth_s)
            return Scored(metrics, fit, warnings, still)
        except ValueError as exc:  # e.g. a ground truth that never moves
            warnings.append(f"alignment {chosen.value} not possible ({exc}); metrics without it")
    try:
        metrics = evaluate_trajectory(trajectory, gt, convention, rte_window_s, smooth_s)
        return Scored(metrics, None, warnings, still)
    except ValueError as exc:  # then the alignment's failure says nothing more
        return Scored(None, None, [f"metrics unavailable: {exc}"], still)


def _stand_still(
    gt: Trajectory, convention: Convention, rte_window_s: float, smooth_s: float | None
) -> TrajectoryMetrics | None:
    try:
        return evaluate_trajectory(stand_still(gt), gt, convention, rte_window_s, smooth_s)
    except ValueError:  # a truth that never moves has no baseline either
        return None


def evaluate_checkpoint(
    loaded: LoadedModel,
    sequences: Iterable[ImuSequence],
    convention: Convention = Convention.RONIN,
    *,
    rte_window_s: float = 60.0,
    stride: int | None = None,
    on_sequence: Callable[[str], None] | None = None,
    alignment: Alignment | str | None = None,
    orientation: str | None = None,
    yaw_copies: int | None = None,
    cyclic_turns: bool | None = None,
    precision: str = "fp32",
    filter: str = NONE,
) -> EvaluationReport:
    """Predict every sequence and score it against its ground truth (``DataFormatError`` if none).
    ``filter`` (``none`` or ``ekf``, module docstring) puts the model inside the EKF.

    ``orientation`` (``ftin.data.orientation_option``) is applied to each sequence before the model;
    ``None`` keeps each sequence's own.

    ``alignment`` (``ftin.metrics.alignment_modes``) sets the convention it implies; ``None`` with the
    RoNIN convention picks each sequence's default (``start`` where the ground truth may be in another
    world frame than the device's, else ``none``); ``None`` with another convention scores as before.
    """
    if alignment is not None:
        convention = convention_for(alignment)
    convention = Convention(convention)
    filter = parse_filter(filter)
    predict = evaluation_predictor(
        filter,
        orientation=orientation,
        precision=precision,
        stride=stride,
        yaw_copies=yaw_copies,
        cyclic_turns=cyclic_turns,
    )
    results: list[SequenceResult] = []
    truth = ("gt", "has no ground truth: it cannot be evaluated")
    for seq, prediction in each_prediction(loaded, sequences, predict, truth, on_sequence):
        scored = score(prediction, alignment, convention, rte_window_s)
        if scored.metrics is None:
            raise DataFormatError(f"sequence {seq.name!r}: {'; '.join(scored.warnings[-1:])}")
        duration_s = prediction.trajectory.duration_s  # the prepared recording's span
        warnings = [*prediction.warnings, *scored.warnings]
        results.append(
            SequenceResult(
                seq.name,
                scored.metrics,
                duration_s,
                warnings,
                scored.stand_still,
                prediction.orientation_choice,
                uncertainty_coverage(prediction, loaded.name, seq),
                mean_tilt_error_deg(prediction),
                heading_error_of(prediction.trajectory, scored.truth_in_estimate_frame(prediction.truth)),
            )
        )
    if not results:
        raise ValueError("evaluate_checkpoint needs at least one sequence")
    stills = [r.stand_still for r in results if r.stand_still is not None]
    return EvaluationReport(
        checkpoint=loaded.name,
        convention=convention,
        rte_window_s=float(rte_window_s),
        sequences=results,
        mean=mean_metrics([r.metrics for r in results]),
        stand_still=mean_metrics(stills) if stills else None,
        filter=filter,
    )


Predict = Callable[[LoadedModel, ImuSequence], Prediction]


def evaluation_predictor(
    filter: str = NONE,
    *,
    orientation: str | None = None,
    precision: str = "fp32",
    stride: int | None = None,
    yaw_copies: int | None = None,
    cyclic_turns: bool | None = None,
) -> Predict:
    """How an evaluation reads each recording: with ``filter`` ekf the EKF's answer (the filter levels
    the phone, the model reads it again: ``ftin.filter.levelled``), else inference with these options
    (``precision``: ``ftin.precision``; reported numbers are fp32 unless asked). Neither keeps the
    prepared copy of the recording: an evaluation reads many."""
    if parse_filter(filter) == EKF:
        return lambda loaded, seq: ekf_prediction(loaded, seq, orientation=orientation, keep_prepared=False)

    def infer(loaded: LoadedModel, seq: ImuSequence) -> Prediction:
        return predict_trajectory(
            loaded,
            seq,
            precision=precision,
            stride=stride,
            keep_prepared=False,
            orientation=orientation,
            yaw_copies=yaw_copies,
            cyclic_turns=cyclic_turns,
        )

    return infer


def each_prediction(
    loaded: LoadedModel,
    sequences: Iterable[ImuSequence],
    predict: Predict,
    needs: tuple[str, str],
    on_sequence: Callable[[str], None] | None = None,
) -> Iterator[tuple[ImuSequence, Prediction]]:
    """Each of ``sequences`` in order with ``predict(loaded, seq)``, announced to ``on_sequence`` before
    it is predicted. ``needs``: the ``ImuSequence`` field it is scored against (``gt``, ``waypoints``)
    and, for one without it, the ``DataFormatError``'s words after the sequence's name."""
    field_name, refusal = needs
    for seq in sequences:
        if getattr(seq, field_name) is None:
            raise DataFormatError(f"sequence {seq.name!r} {refusal}")
        if on_sequence is not None:
            on_sequence(seq.name)
        yield seq, predict(loaded, seq)


def mean_tilt_error_deg(prediction: Prediction) -> float | None:
    """Mean angle (deg) between the gravity direction of the orientation the answer used and the
    ground truth's, over its tracked samples; None where the truth has no orientation."""
    truth, q = prediction.truth, prediction.trajectory.q_world_body_wxyz
    if truth is None or truth.q_world_body_wxyz is None or q is None or len(q) != len(truth.t_s):
        return None
    tracked = slice(None) if truth.tracked is None else truth.tracked
    errors = tilt_error_deg(q[tracked], truth.q_world_body_wxyz[tracked])
    return float(errors.mean()) if len(errors) else None


def uncertainty_coverage(prediction: Prediction, checkpoint: str, seq: ImuSequence) -> Coverage | None:
    """How well ``prediction``'s uncertainty covers its prepared ground truth (None without either)."""
    found = path_uncertainty(prediction, checkpoint, seq.meta.get("carry"))
    truth = prediction.truth
    if found is None or truth is None:
        return None
    try:
        return coverage_of(prediction.trajectory, found.cov_m2, truth, found.end_radius_95_m)
    except ValueError:  # a truth the start alignment cannot fit (one that never moves): no coverage
        return None
