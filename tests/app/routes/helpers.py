"""What the route tests share: the fixture checkpoints' names and small request helpers."""

from __future__ import annotations

import pandas as pd
from fastapi.testclient import TestClient

DEFAULT_MODEL = "ftin-oxiod"
OTHER_MODEL = "resnet-tiny"


def upload(client: TestClient, data: bytes, name: str = "walk.csv", **params: str):
    return client.post("/predict", params=params, files={"file": (name, data, "text/csv")})


ARRAY_COLUMNS = {  # POST /predict's JSON arrays -> the generic CSV's columns
    "t_s": "t",
    "gyro_rad_s": ["gyro_x", "gyro_y", "gyro_z"],
    "acc_m_s2": ["acc_x", "acc_y", "acc_z"],
    "q_world_device_wxyz": ["q_w", "q_x", "q_y", "q_z"],
    "gt_p_world_m": [f"gt_device_world_{a}" for a in "xyz"],
}


def arrays_body(frame: pd.DataFrame, *fields: str, **extra: str) -> dict[str, object]:
    """A JSON body for ``POST /predict`` with ``fields`` (keys of ``ARRAY_COLUMNS``) taken from ``frame``."""
    return {**extra, **{f: frame[ARRAY_COLUMNS[f]].to_numpy().tolist() for f in fields}}


def detail(response) -> str:
    body = response.json()
    assert set(body) == {"detail"}, body
    assert isinstance(body["detail"], str)
    return body["detail"]
