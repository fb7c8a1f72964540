"""Request and response bodies of the REST API (pydantic), and their conversion from library types.

Units follow the library: seconds, metres, m/s, rad/s, m/s². Trajectories travel as parallel arrays
``{t, x, y, z}`` (compact, and what plotting code wants). The server's own state (``GET /health``)
is in ``app.schemas_health``, what ``GET /models`` and ``GET /sequences`` list in ``app.schemas_catalog``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, create_model

from app.schemas_heading import HeadingErrorPayload, OrientationStretchPayload, heading_error_json
from app.schemas_profiles import AppliedProfilePayload
from app.schemas_uncertainty import UncertainTrajectoryPayload, UncertaintyPayload
from app.schemas_verdict import LoopClosurePayload, StepLengthPayload, VerdictPayload
from app.schemas_waypoints import WaypointMetricsPayload
from app.services.runs import Run, RunStatus
from app.services.verdict import loop_closure_of, z_note
from ftin.data import Trajectory
from ftin.filter.choice import filter_of
from ftin.metrics import HEADLINE_METRIC, describe, describe_alignment, list_metrics


class ErrorResponse(BaseModel):
    detail: str = Field(description="What was wrong with the request, in plain words.")


class ArraysPredictRequest(BaseModel):
    """An IMU recording as arrays (the JSON alternative to uploading a CSV)."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field("recording", max_length=200, description="A label for the recording.")
    t_s: list[float] = Field(description="Timestamps in seconds, increasing, N values.")
    gyro_rad_s: list[list[float]] = Field(description="N rows of device-frame angular rate x, y, z (rad/s).")
    acc_m_s2: list[list[float]] = Field(
        description="N rows of device-frame specific force x, y, z (m/s², +9.81 up when flat)."
    )
    q_world_device_wxyz: list[list[float]] | None = Field(
        None, description="Optional N rows of device orientation (w, x, y, z); estimated when absent."
    )
    gt_p_world_m: list[list[float]] | None = Field(
        None, description="Optional N rows of ground-truth position x, y, z (m); enables metrics."
    )
    mag_uT: list[list[float]] | None = Field(
        None,
        description="Optional N rows of device-frame magnetic field x, y, z (µT): the orientation filter "
        "then references its heading to magnetic north (VQF 9-D).",
    )


class TrajectoryPayload(BaseModel):
    t: list[float]
    x: list[float]
    y: list[float]
    z: list[float]

    @classmethod
    def from_trajectory(cls, traj: Trajectory) -> TrajectoryPayload:
        p = np.asarray(traj.p_world_m)
        return cls(t=traj.t_s.tolist(), x=p[:, 0].tolist(), y=p[:, 1].tolist(), z=p[:, 2].tolist())


class VelocityPayload(BaseModel):
    t: list[float] = Field(description="Window times in seconds.")
    vx: list[float]
    vy: list[float]
    vz: list[float] | None = Field(description="Only for models that predict 3-D velocity.")


class MetricInfo(BaseModel):
    """One registered metric (``ftin.metrics.registry``): how a client names, shows and reads it."""

    name: str = Field(description="The key of its value in every metrics object.")
    label: str = Field(description="Short name for table headers.")
    unit: str = Field(description="Unit of the value as given ('' for a ratio).")
    description: str
    better: str = Field(description="lower, higher, closer to 1, or neither (a figure, not a score).")
    needs_truth: bool
    in_tables: bool = Field(description="Shown as a column of the compact tables.")
    scale: float = Field(description="Shown as value * scale in display_unit (a ratio as a percentage).")
    display_unit: str
    digits: int = Field(description="Decimals shown.")
    headline: bool = Field(False, description="The headline metric (the standing-still baseline's figure).")


def metric_infos() -> list[MetricInfo]:
    return [MetricInfo(**m.as_dict(), headline=m.name == HEADLINE_METRIC) for m in list_metrics()]


class _MetricsPayloadBase(BaseModel):
    """How the values were scored; the values themselves are one field per registered metric."""

    convention: str = Field("ronin", description="How the estimate is aligned before scoring.")
    convention_text: str = Field("", description="The convention, the units and the definitions in words.")
    rte_window_s: float = Field(60.0, description="RTE window, s.")
    smooth_s: float | None = Field(
        None, description="Seconds both paths were smoothed over before their lengths (the model's window)."
    )
    duration_s: float | None = Field(
        None, description="Length of the recording, s (below rte_window_s, RTE is the scaled drift)."
    )
    stand_still: dict[str, float | None] | None = Field(
        None, description="The table metrics of a predictor that never moves, same convention: the baseline."
    )
    alignment: str | None = Field(
        None, description="none, start, se2 or se3: how the prediction was aligned before scoring (align=)."
    )
    heading_deg: float | None = Field(
        None, description="Fitted heading of the prediction into the ground-truth frame, deg (None: none)."
    )
    align_window_s: float | None = Field(None, description="Seconds of the start fitted on (align=start).")
    alignment_text: str = Field("", description="The alignment in words.")
    worse_than_standing_still: bool | None = Field(
        None, description="True when the model's ATE is at or above standing still's (None: no baseline)."
    )
    standing_still_text: str | None = Field(None, description="The comparison with standing still, in words.")
    scope_note: str | None = Field(
        None, description="Why ATE / RTE / PDE mean little here (too short or too confined), if they do."
    )

    @classmethod
    def from_run(cls, run: Run) -> MetricsPayload | None:
        metrics = run.metrics
        if metrics is None:
            return None
        verdict = run.verdict
        still = verdict.still
        t = np.asarray(run.prediction.trajectory.t_s)
        return cls(
            **{name: _finite(value) for name, value in metrics.values.items()},
            convention=metrics.convention.value,
            convention_text=describe(metrics.convention, metrics.rte_window_s),
            rte_window_s=metrics.rte_window_s,
            smooth_s=metrics.smooth_s,
            duration_s=float(t[-1] - t[0]) if len(t) > 1 else None,
            stand_still=verdict.stand_still,
            **_alignment_fields(metrics),
            worse_than_standing_still=None if still is None else still.worse_than_standing_still,
            standing_still_text=None if still is None else still.text,
            scope_note=verdict.scope_note,
        )


# One field per registered metric (None where undefined for this sequence, e.g. not finite): the
# schema follows the registry, so a new metric needs no edit here.
MetricsPayload = create_model(
    "MetricsPayload",
    __base__=_MetricsPayloadBase,
    **{
        m.name: (
            float | None,
            Field(None, description=f"{m.label}: {m.description}" + (f", {m.unit}" if m.unit else "")),
        )
        for m in list_metrics()
    },
)


def _alignment_fields(metrics: Any) -> dict[str, Any]:
    """The alignment of a ``TrajectoryMetrics`` (``ftin.metrics.alignment_modes``), for ``MetricsPayload``."""
    if metrics.alignment is None:
        return {}
    heading = metrics.heading_deg
    return {
        "alignment": metrics.alignment,
        "heading_deg": None if heading is None else _finite(heading),
        "align_window_s": metrics.align_window_s,
        "alignment_text": describe_alignment(metrics.alignment),
    }


class FigurePayload(BaseModel):
    name: str
    unit: str
    value: float | None = Field(description="None where the figure is undefined (e.g. no steps detected).")
    description: str


class GpsPayload(BaseModel):
    """The export's GPS fixes in the prediction's frame (aligned at the start), and how they compare."""

    t: list[float] = Field(description="Time of each fix on the recording's clock, s.")
    x: list[float] = Field(description="Fix positions in the prediction's frame, m.")
    y: list[float]
    accuracy_m: list[float | None] = Field(description="Horizontal accuracy of each fix, m (None: unknown).")
    figures: list[FigurePayload]


class PlausibilityPayload(BaseModel):
    """Figures that need no ground truth (ftin.metrics.plausibility) and the warnings they raise."""

    figures: list[FigurePayload]
    warnings: list[str]
    gps: GpsPayload | None = Field(None, description="Present when the export has GPS fixes (Location.csv).")
    step_times_s: list[float] | None = Field(
        None, description="Times of the detected steps, s on the trajectory's clock (null: not detected)."
    )
    step_length: StepLengthPayload | None = Field(
        None, description="One step length, labelled: from the path and from the cadence."
    )
    loop_closure: LoopClosurePayload | None = Field(
        None,
        description="Present when the walk returns near its start: by the ground truth or good GPS, else "
        "a prediction ending within 10 % of its path from its start after 20 m or more (docs/metrics.md).",
    )

    @classmethod
    def from_run(cls, run: Run) -> PlausibilityPayload:
        p = run.plausibility
        gps = None
        if p.gps is not None:
            accuracy = [None if not math.isfinite(a) else float(a) for a in p.gps.accuracy_m]
            gps = GpsPayload(
                t=p.gps.t_s.tolist(),
                x=p.gps.p_m[:, 0].tolist(),
                y=p.gps.p_m[:, 1].tolist(),
                accuracy_m=accuracy,
                figures=[FigurePayload(**vars(f)) for f in p.gps_figures],
            )
        return cls(
            figures=[FigurePayload(**vars(f)) for f in p.figures],
            warnings=p.warnings,
            gps=gps,
            step_times_s=None if p.steps is None else np.round(p.steps.t_s, 3).tolist(),
            step_length=StepLengthPayload(**p.step_length.as_dict()),
            loop_closure=loop_closure_of(run),
        )


class OrientationChoicePayload(BaseModel):
    requested: str = Field(description="The orientation asked for: auto, device, vqf, vqf6d or ground_truth.")
    source: str = Field(description="The source that ran: device, vqf, vqf6d or ground_truth.")
    reason: str = Field(description="Why, in words (for auto: what the recording showed).")
    magnetometer: str | None = Field(
        None,
        description="What the magnetometer check did where it did not use the field as given: calibrated "
        "hard and soft iron from the recording's own turns, or dropped it (docs/orientation.md); null: as "
        "given or not read.",
    )
    stretches: list[OrientationStretchPayload] | None = Field(
        None,
        description="Where auto judged the magnetometer stretch by stretch (ftin.data.mag_trust): what each "
        "stretch's heading used and why; null: the walk-level choice ran throughout.",
    )


class ModelChoicePayload(BaseModel):
    model: str
    rule: str = Field(
        description="requested (named in the request), sequence (the listed sequence's suggested model), "
        "upload_kind (the model for the upload's recognised kind) or default."
    )
    reason: str = Field(description="The rule in words.")


class PredictionResponse(BaseModel):
    run_id: str
    model: str
    sequence: str
    source: str
    trajectory: UncertainTrajectoryPayload
    ground_truth: TrajectoryPayload | None
    velocity: VelocityPayload
    orientation_source: str
    orientation_choice: OrientationChoicePayload | None = Field(
        None, description="The orientation asked for, the source that ran and why."
    )
    model_choice: ModelChoicePayload | None = Field(
        None, description="Why this model ran: the one named, or the rule that chose it when none was."
    )
    frame: str
    warnings: list[str] = Field(description="What may be wrong with this result (path length included).")
    notes: list[str] = Field(
        default_factory=list, description="Information on how the input was read (time unit, resampling)."
    )
    metrics: MetricsPayload | None = Field(
        description="Every registered metric by name (GET /metrics says which)."
    )
    heading_error: HeadingErrorPayload | None = Field(
        None, description="Heading error over 10-s windows against the ground truth (None: no ground truth)."
    )
    plausibility: PlausibilityPayload | None = Field(
        None, description="Path length, speed, steps, cadence, step length, GPS: figures without ground truth"
    )
    csv_url: str
    tum_url: str = Field("", description="The trajectory in TUM format (evo): /runs/{run_id}/trajectory.tum.")
    ground_truth_tum_url: str | None = Field(
        None, description="The ground truth in TUM format, in the prediction's frame (None: no ground truth)."
    )
    metrics_url: str = Field("", description="The metrics as JSON: GET /runs/{run_id}/metrics.json.")
    scene_url: str | None
    z_note: str | None = Field(
        None, description="Why z is a constant (a model that predicts horizontal motion only), if it is."
    )
    verdict: VerdictPayload | None = Field(
        None, description="Does it look like a walk, read right? (ok/check/implausible)"
    )
    uncertainty: UncertaintyPayload | None = Field(None, description="How sure: the 95 % end radius.")
    waypoints: WaypointMetricsPayload | None = Field(
        None,
        description="Scores at the waypoints where the truth is sparse (ILC traces); absent otherwise.",
        exclude_if=lambda value: value is None,
    )
    # Only where asked: an answer without the filter stays as it was (docs/filter.md).
    filter: str = Field(
        "none",
        description="The filter the model ran in: ekf (the network inside the EKF, docs/filter.md); "
        "absent for none.",
        exclude_if=lambda value: value == "none",
    )
    profile: AppliedProfilePayload | None = Field(
        None,
        description="The walker profile that scaled the prediction (POST /predict?profile=); absent: none.",
        exclude_if=lambda value: value is None,
    )

    @classmethod
    def from_run(cls, run: Run, scene_url: str | None) -> PredictionResponse:
        pred = run.prediction
        v = np.asarray(pred.velocity_m_s)
        verdict = run.verdict
        return cls(
            run_id=run.run_id,
            model=run.model_name,
            sequence=run.sequence.name,
            source=run.source,
            trajectory=UncertainTrajectoryPayload.from_run(run),
            ground_truth=None if run.truth is None else TrajectoryPayload.from_trajectory(run.truth),
            velocity=VelocityPayload(
                t=np.asarray(pred.window_t_s).tolist(),
                vx=v[:, 0].tolist(),
                vy=v[:, 1].tolist(),
                vz=v[:, 2].tolist() if v.shape[1] > 2 else None,
            ),
            orientation_source=str(pred.orientation_source),
            orientation_choice=pred.orientation_choice,
            model_choice=None if run.model_choice is None else run.model_choice.to_json(),
            frame=str(pred.frame),
            warnings=verdict.warnings,
            notes=[*verdict.notes, *run.plausibility.notes],  # GPS fixes left out, if any
            metrics=MetricsPayload.from_run(run),
            heading_error=heading_error_json(run),
            plausibility=PlausibilityPayload.from_run(run),
            csv_url=f"/runs/{run.run_id}/trajectory.csv",
            tum_url=f"/runs/{run.run_id}/trajectory.tum",
            ground_truth_tum_url=None if run.truth is None else f"/runs/{run.run_id}/ground_truth.tum",
            metrics_url=f"/runs/{run.run_id}/metrics.json",
            scene_url=scene_url,
            z_note=z_note(run),
            verdict=VerdictPayload.from_run(run),
            uncertainty=UncertaintyPayload.from_run(run),
            waypoints=WaypointMetricsPayload.from_run(run),
            filter=filter_of(pred),
            profile=AppliedProfilePayload.from_run(run),
        )


class RunStatusResponse(BaseModel):
    run_id: str
    state: str = Field(
        description="running, done, failed, or damaged (finished, but its stored files are missing or "
        "damaged: message says why; its downloads answer 410)."
    )
    model: str
    sequence: str
    done: int
    total: int
    message: str

    @classmethod
    def from_status(cls, status: RunStatus) -> RunStatusResponse:
        return cls(
            run_id=status.run_id,
            state=status.state.value,
            model=status.model_name,
            sequence=status.sequence_name,
            done=status.done,
            total=status.total,
            message=status.message,
        )


def _finite(value: Any) -> float | None:
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None
