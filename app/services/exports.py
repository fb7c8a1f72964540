"""What a finished run exports: its trajectory as CSV, TUM trajectories for evo, the metrics as JSON,
and the trajectory at the input's own timestamps (``GET /runs/{run_id}/...``).

Decisions:
- Frames: the predicted trajectory is in the prediction's world frame; the ground truth exported
  beside it is the one the run keeps, already moved into that frame by the fitted alignment
  (``PredictionService.run``), so ``evo_ape tum ground_truth.tum trajectory.tum`` without ``--align``
  reproduces the run's unaligned comparison and ``--align`` / ``--n_to_align`` apply evo's own.
- ``timestamps=model`` (default): the samples the model ran on (the checkpoint's rate);
  ``timestamps=input``: interpolated at the recording's own timestamps inside the predicted span
  (a 200 Hz upload comes back at 200 Hz; for a phone export, its merged sensor clock).
- Timestamps are seconds from the start of the recording, as in every other output.
- A model that predicts horizontal velocity only holds z at its start: the ground truth's start
  height, else 0. Both files say so in a ``#`` comment first (``z_note``), as the page does.
- ``metrics.json`` carries what ``POST /predict`` answers about the scores (its ``metrics`` object,
  field for field, ``plausibility``, ``warnings`` and ``notes``), plus the metric definitions.
"""

from __future__ import annotations

import io
from enum import Enum
from typing import Any

import numpy as np

from app.schemas import MetricsPayload, PlausibilityPayload  # the fields POST /predict answers
from app.services.runs import Run
from app.services.verdict import z_note
from ftin.data.trajectory_io import at_times, tum_text
from ftin.data.types import Trajectory
from ftin.metrics import list_metrics


class Timestamps(str, Enum):
    MODEL = "model"
    INPUT = "input"


def trajectory_at(run: Run, timestamps: Timestamps | str = Timestamps.MODEL) -> Trajectory:
    traj = run.prediction.trajectory
    if Timestamps(timestamps) is Timestamps.INPUT:
        return at_times(traj, run.sequence.t_s)
    return traj


def trajectory_csv(run: Run, timestamps: Timestamps | str = Timestamps.MODEL) -> str:
    """``t_s,x_m,y_m,z_m`` in the prediction's world frame, after a ``#`` line when z is constant."""
    traj = trajectory_at(run, timestamps)
    buffer = io.StringIO()
    note = z_note(run)
    if note is not None:
        buffer.write(f"# {note}\n")
    table = np.column_stack([traj.t_s, traj.p_world_m])
    np.savetxt(buffer, table, delimiter=",", fmt="%.6f", header="t_s,x_m,y_m,z_m", comments="")
    return buffer.getvalue()


def trajectory_tum(run: Run, timestamps: Timestamps | str = Timestamps.MODEL) -> str:
    comment = (
        f"FTIN Studio: {run.model_name} on {run.sequence.name}, {run.prediction.frame} frame, "
        f"orientation {run.prediction.orientation_source}, timestamps: {Timestamps(timestamps).value}"
    )
    note = z_note(run)
    if note is not None:
        comment += f"\n{note}"
    return tum_text(trajectory_at(run, timestamps), comment)


def ground_truth_tum(run: Run) -> str | None:
    gt = run.truth
    if gt is None:
        return None
    m = run.metrics
    how = "" if m is None or m.alignment is None else f", alignment {m.alignment} applied"
    return tum_text(gt, f"FTIN Studio: ground truth of {run.sequence.name} in the prediction's frame{how}")


def metrics_json(run: Run) -> dict[str, Any]:
    """What ``POST /predict`` says about the run's scores, without the trajectories."""
    metrics = MetricsPayload.from_run(run)
    return {
        "run_id": run.run_id,
        "model": run.model_name,
        "sequence": run.sequence.name,
        "orientation_source": run.prediction.orientation_source,
        "orientation_filter": run.prediction.orientation_filter,
        "orientation_choice": run.prediction.orientation_choice,
        "model_choice": None if run.model_choice is None else run.model_choice.to_json(),
        "frame": run.prediction.frame,
        "metrics": None if metrics is None else metrics.model_dump(),
        "metric_definitions": [metric.as_dict() for metric in list_metrics()],
        "plausibility": PlausibilityPayload.from_run(run).model_dump(),
        "warnings": run.verdict.warnings,
        "notes": run.verdict.notes,
        "z_note": z_note(run),
    }
