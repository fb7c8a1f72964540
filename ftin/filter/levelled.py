"""The filter as the network's leveller: the network re-read on the EKF's orientation, integrated as
inference integrates (``docs/filter.md``, "The levelled network").

The EKF's own path follows one network window a second, integrated IMU between them; inference reads
overlapping windows with its canonical looks and the body-locked heading (``ftin.infer``). The
filter's gain is its tilt, so here the filter only levels the phone: it runs twice (the second pass
from where the first settled, ``ftin.filter.settle``), then ``predict_trajectory`` reads the recording
once more with the filter's orientation in place of the orientation filter's. Where the
network disagreed with the IMU all walk (mean NIS over ``MAX_MEAN_NIS``: running, AR, a walker or
phone whose windows the network misreads), the filter's tilt was pulled by wrong velocities (worse than
VQF's on such walks), so the orientation filter's is kept. Offline: the mean NIS is the whole walk's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ftin.checkpoint import LoadedModel
from ftin.data.types import ImuSequence
from ftin.filter.run import FilterRun, filter_prediction
from ftin.filter.state import FilterConfig
from ftin.infer import Prediction, predict_trajectory

# Five times a 3-dof NIS's expectation: the network's errors over twice the sigma the filter was told.
# The validation walks allow 13-61 (Inria: a running walk at 13 levels well, the AR walks at 61-145 do
# not); 15 is the round rule inside that range (docs/results/probes/ekf_levelled.md).
MAX_MEAN_NIS = 15.0


@dataclass
class Levelled:
    """The re-read ``prediction`` (its ``orientation_filter`` is ``ekf``), the filter's ``run``, whether
    the filter's orientation was used (``levelled``) and the orientation the filter started from."""

    prediction: Prediction
    run: FilterRun
    levelled: bool
    q_start_wxyz: np.ndarray


def network_agreed(nis: np.ndarray) -> bool:
    """The rule (module docstring): whether the network agreed with the IMU over these updates, their
    mean NIS at most ``MAX_MEAN_NIS`` (no update yet: nothing disagreed). Uploads apply it to the whole
    walk, live sessions to the walk so far."""
    return not len(nis) or float(np.mean(nis)) <= MAX_MEAN_NIS


def levelled_prediction(
    loaded: LoadedModel,
    seq: ImuSequence,
    orientation: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Levelled:
    """``loaded`` over ``seq`` (prepared with ``orientation`` as inference prepares it) read on the EKF's
    orientation (its second pass, the filter as ``FilterConfig``'s defaults set it: the rule above was
    fitted on them) where the filter agreed with the network, else on the orientation it started from.
    ``progress`` follows the filter's passes (the re-read takes a few per cent of their time)."""
    filtered, run = filter_prediction(loaded, seq, FilterConfig(), orientation, progress, passes=2)
    prepared = filtered.prepared.seq
    mean_nis = float(np.mean(run.nis))
    levelled = network_agreed(run.nis)
    q = run.q_world_device_wxyz if levelled else prepared.q_world_device_wxyz
    prediction = predict_trajectory(loaded, prepared.with_(q_world_device_wxyz=q))
    prediction.orientation_filter = "ekf"
    if levelled:
        prediction.notes.append(f"read on the EKF's orientation (mean NIS {mean_nis:.1f}, its second pass)")
    else:
        prediction.notes.append(
            f"the EKF's orientation not used: the network disagreed with the IMU (mean NIS {mean_nis:.1f}"
            f" > {MAX_MEAN_NIS:g})"
        )
    return Levelled(prediction, run, levelled, prepared.q_world_device_wxyz)
