"""What a finished run exports: its trajectory as CSV, TUM trajectories for evo
and the trajectory at the input's own timestamps (``GET /runs/{run_id}/...``).

Decisions:
- Frames: the predicted trajectory is in the prediction's world frame; the ground truth exported
  beside it is the one the run keeps, already moved into that frame by the fitted alignment
  (``PredictionService.run``), so ``evo_ape tum ground_truth.tum trajectory.tum`` without ``--align``
  reproduces the run's unaligned comparison and ``--align`` / ``--n_to_align`` apply evo's own.
- ``timestamps=model`` (default): the samples the model ran on (the checkpoint's rate);
  ``timestamps=input``: interpolated at the recording's own timestamps inside the predicted span
  (a 200 Hz upload comes back at 200 Hz; for a phone export, its merged sensor clock).
- Timestamps are seconds from the start of the recording, as in every other output; ``clock=epoch``
  puts them on the phone's own clock instead (seconds since the Unix epoch, UTC, where the export
  says when it started: ``ftin.data.epoch``; a recording that does not answers 422). The CSV's
  first column is then ``t_unix_s``, so a file never leaves its clock unsaid.
- A model that predicts horizontal velocity only holds z at its start: the ground truth's start
  height, else 0. Both files say so in a ``#`` comment first (``z_note``), as the page does.
- ``metrics.json`` is built in its route (``app.api.routes.exports``) from the API's own body types,
  so that this service knows no API schema.
"""

from __future__ import annotations

import io
from enum import Enum

import numpy as np

from app.services.errors import InvalidInputError
from app.services.runs import Run
from app.services.verdict import z_note
from ftin.data.epoch import start_epoch_s
from ftin.data.trajectory_io import at_times, tum_text
from ftin.data.types import Trajectory


class Timestamps(str, Enum):
    MODEL = "model"
    INPUT = "input"


class Clock(str, Enum):
    START = "start"  # seconds from the start of the recording
    EPOCH = "epoch"  # seconds since 1970-01-01 UTC on the phone's clock


def recording_start(run: Run) -> float:
    """When the run's recording started, in seconds since the epoch; 422 where it does not say."""
    start = start_epoch_s(run.sequence.meta)
    if start is None:
        raise InvalidInputError(
            f"{run.sequence.name} has no start time on the phone's clock (Sensor Logger and phyphox "
            "exports, and EuRoC, have one; a plain CSV or a live stream does not): download it with "
            "clock=start, seconds from the start of the recording"
        )
    return start


def trajectory_at(
    run: Run, timestamps: Timestamps | str = Timestamps.MODEL, clock: Clock | str = Clock.START
) -> Trajectory:
    traj = run.prediction.trajectory
    if Timestamps(timestamps) is Timestamps.INPUT:
        traj = at_times(traj, run.sequence.t_s)
    if Clock(clock) is Clock.EPOCH:
        traj = Trajectory(traj.t_s + recording_start(run), traj.p_world_m, traj.q_world_body_wxyz)
    return traj


def trajectory_csv(
    run: Run, timestamps: Timestamps | str = Timestamps.MODEL, clock: Clock | str = Clock.START
) -> str:
    """``t_s,x_m,y_m,z_m,sigma_x_m,sigma_y_m`` (``t_unix_s,...`` on the epoch clock) in the prediction's
    world frame, after a ``#`` line when z is constant; the sigmas (``ftin.uncertainty``) where the run
    has them."""
    traj = trajectory_at(run, timestamps, clock)
    buffer = io.StringIO()
    note = z_note(run)
    if note is not None:
        buffer.write(f"# {note}\n")
    columns, header = [traj.t_s, traj.p_world_m], "x_m,y_m,z_m"
    if run.uncertainty is not None:  # on the exported times: the model's, or the input's interpolated
        model_t, sigma = run.prediction.trajectory.t_s, run.uncertainty.sigma_m()
        at = traj.t_s - (recording_start(run) if Clock(clock) is Clock.EPOCH else 0.0)
        columns += [np.interp(at, model_t, sigma[:, 0]), np.interp(at, model_t, sigma[:, 1])]
        header += ",sigma_x_m,sigma_y_m"
    table = np.column_stack(columns)
    time = "t_unix_s" if Clock(clock) is Clock.EPOCH else "t_s"
    np.savetxt(buffer, table, delimiter=",", fmt="%.6f", header=f"{time},{header}", comments="")
    return buffer.getvalue()


def trajectory_tum(
    run: Run, timestamps: Timestamps | str = Timestamps.MODEL, clock: Clock | str = Clock.START
) -> str:
    on = "Unix time (s since 1970, UTC)" if Clock(clock) is Clock.EPOCH else "s from the start"
    comment = (
        f"FTIN Studio: {run.model_name} on {run.sequence.name}, {run.prediction.frame} frame, "
        f"orientation {run.prediction.orientation_source}, timestamps: {Timestamps(timestamps).value}, {on}"
    )
    note = z_note(run)
    if note is not None:
        comment += f"\n{note}"
    return tum_text(trajectory_at(run, timestamps, clock), comment)


def ground_truth_tum(run: Run, clock: Clock | str = Clock.START) -> str | None:
    gt = run.truth
    if gt is None:
        return None
    m = run.metrics
    how = "" if m is None or m.alignment is None else f", alignment {m.alignment} applied"
    if Clock(clock) is Clock.EPOCH:
        gt = Trajectory(gt.t_s + recording_start(run), gt.p_world_m, gt.q_world_body_wxyz)
        how += ", Unix time (s since 1970, UTC)"
    return tum_text(gt, f"FTIN Studio: ground truth of {run.sequence.name} in the prediction's frame{how}")
