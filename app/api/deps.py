"""Annotated dependencies shared by the routers."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Query, Request

from app.services import Services
from ftin.data.orientation_option import Orientation
from ftin.metrics import Alignment


def get_services(request: Request) -> Services:
    return request.app.state.services


ServicesDep = Annotated[Services, Depends(get_services)]

ModelQuery = Annotated[
    str | None,
    Query(
        description="Model name from GET /models. When omitted: a listed sequence's suggested_model, else "
        "the model trained on an upload's recognised kind, else the default (model_choice says which).",
        max_length=200,
    ),
]
RunIdQuery = Annotated[
    str | None,
    Query(
        description="Optional client-chosen run id (6-64 of A-Z a-z 0-9 - _), to poll GET /runs/{run_id}"
        " for progress while the request runs.",
        max_length=64,
    ),
]
AlignQuery = Annotated[
    Alignment | None,
    Query(
        description="How the prediction is aligned to the ground truth before scoring: none (RoNIN, raw), "
        "start (heading and start fitted on the first seconds only, like evo --n_to_align), se2 or se3 "
        "(whole-trajectory Umeyama, like evo --align). Default: start when the ground truth may live in "
        "another world frame than the device's (a CSV's gt_x columns), else none.",
    ),
]
OrientationQuery = Annotated[
    Orientation,
    Query(
        description="Which orientation the model reads: auto (chosen from the recording: the magnetometer's "
        "disturbance, the phone attitude's north and level; docs/orientation.md), device (the phone's own "
        "attitude), vqf (VQF 9-D from gyroscope, accelerometer and magnetometer; 6-D without one), vqf6d "
        "(VQF without the magnetometer) or ground_truth (the recording's motion capture, where it has one). "
        "The answer's orientation_choice names the source that ran and why.",
    ),
]
