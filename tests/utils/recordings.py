"""Recordings built for the dashboard tests from the bundled sample's frame."""

from __future__ import annotations

import numpy as np
import pandas as pd


def still_phone_csv(sample_frame: pd.DataFrame) -> bytes:
    """The phone lies still on a table (identity orientation, gravity only) while the ground truth
    walks (13 m in the first 20 s of the bundled walk)."""
    frame = sample_frame.copy()
    rng = np.random.default_rng(0)
    for column in ("gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y"):
        frame[column] = rng.normal(0.0, 1e-3, len(frame))
    frame["acc_z"] = 9.81 + rng.normal(0.0, 1e-3, len(frame))
    frame["q_w"], frame["q_x"], frame["q_y"], frame["q_z"] = 1.0, 0.0, 0.0, 0.0
    return frame.to_csv(index=False).encode()
