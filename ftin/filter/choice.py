"""``filter=none|ekf``: the choice every door offers (API, CLI, page, scene), parsed once here, and the
EKF's prediction as the doors use it (``docs/filter.md``, "At every door").

With ``ekf`` an upload's answer is the model re-read on the filter's orientation (``ftin.filter.levelled``:
the filter levels the phone, the network reads the levelled IMU as inference reads it; the orientation it
started from where the walk's NIS says the network and the IMU disagreed), with the model's own path
uncertainty (``ftin.uncertainty``) since the path is the integrated network's; ``Prediction.features``
carries the filter's tilt and bias estimates as ``filter_series`` for the scene's timeline. A live
session does the same causally (``ftin.live.session``: the model reads each chunk on the filter's
orientation as it comes). ``none`` leaves inference as it always was.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ftin.checkpoint import LoadedModel
from ftin.data.errors import DataFormatError
from ftin.data.types import ImuSequence
from ftin.filter.consistency import tilt_error_deg
from ftin.filter.levelled import levelled_prediction
from ftin.filter.run import FilterRun
from ftin.infer import Prediction

FILTERS = ("none", "ekf")
NONE, EKF = FILTERS


def parse_filter(value: str | None) -> str:
    """``none`` (also for None or an empty value) or ``ekf``; ``ValueError`` naming the field else."""
    if value is None or str(value).strip() == "":
        return NONE
    name = str(value).strip().lower()
    if name not in FILTERS:
        raise ValueError(f"filter must be one of {', '.join(FILTERS)}; got {value!r}")
    return name


def filter_of(prediction: Any) -> str:
    """The filter a prediction was made with: ``ekf`` where the EKF made it, else ``none``."""
    return EKF if getattr(prediction, "orientation_filter", None) == EKF else NONE


def ekf_series(run: FilterRun, q_input_wxyz: np.ndarray) -> dict[str, np.ndarray]:
    """What the scene's timeline plots of an EKF run, per sample: the device's tilt from level (deg),
    how far the EKF moved it from the orientation it started from (deg), both bias estimates."""
    q = run.q_world_device_wxyz
    level = np.tile([1.0, 0.0, 0.0, 0.0], (len(q), 1))
    return {
        "t_s": run.t_s,
        "tilt_deg": tilt_error_deg(q, level),
        "tilt_correction_deg": tilt_error_deg(q, q_input_wxyz),
        "gyro_bias_deg_s": np.degrees(run.gyro_bias_rad_s),
        "acc_bias_m_s2": run.acc_bias_m_s2,
    }


def ekf_prediction(
    loaded: LoadedModel,
    seq: ImuSequence,
    *,
    orientation: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    keep_prepared: bool = True,
) -> Prediction:
    """``seq`` (oriented, or oriented here as inference would) through the EKF (``FilterConfig``'s
    defaults) with ``loaded`` as its measurement (``orientation``: the choice to apply first, as inference
    takes it), then re-read on the filter's orientation (module docstring); a ``Prediction`` carrying the
    filter's series in
    ``features``. A ``DataFormatError`` beginning "filter ekf:" for what the filter cannot run (a
    streaming model: the EKF needs a window model; a recording shorter than a window), at every door."""
    try:
        read = levelled_prediction(loaded, seq, orientation, progress)
    except ValueError as exc:
        raise DataFormatError(f"filter ekf: {exc}") from None
    prediction = read.prediction
    series = ekf_series(read.run, read.q_start_wxyz)
    prediction.features = {**(prediction.features or {}), "filter_series": series}
    if not keep_prepared:
        prediction.prepared = None
    return prediction
