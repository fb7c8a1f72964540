"""FTIN's intermediate features for the dashboard, computed for one window when the scene asks.

Decision: a run does not keep feature taps. ``ftin.infer`` can return every tap of every window,
but for FTIN that is ~26 kB per window (an hour at 200 Hz with stride 10 would hold ~2 GB while
the run lasts). A run keeps instead exactly what the model saw (``ModelInput``: the world-frame
IMU after orientation and resampling, and the window starts, 24 bytes per sample), and the scene
re-runs the model on the one window under the timeline slider (a few milliseconds). The taps are
then identical to those of the original pass, and a run costs the same memory for any model.

The scene plots the two FDL spectra, averaged over the embedding axis ``d``; models without FDL
produce neither and the scene says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from ftin.yaw_average import cyclic_angles, turn_windows

CHANNEL_SPECTRUM = "fdl_channel_spectrum"  # one window: (C_res // 2 + 1, L_res)
TEMPORAL_SPECTRUM = "fdl_temporal_spectrum"  # one window: (C_res, L_res // 2 + 1)
DASHBOARD_TAPS = (CHANNEL_SPECTRUM, TEMPORAL_SPECTRUM)


@dataclass(frozen=True)
class ModelInput:
    """The model's input for a whole run: window ``k`` is ``imu_world[starts[k] : starts[k] + window]``."""

    imu_world: np.ndarray  # (N, 6) float32, gyro xyz then acc xyz, gravity-aligned world frame
    starts: np.ndarray  # (M,) int64 first sample of each window
    window: int
    turn_stride: int | None = None  # windows turned as the model saw them (Prediction.turn_stride)

    def window_batch(self, index: int) -> torch.Tensor:
        """Window ``index`` as a ``(1, 6, L)`` batch, as the model saw it."""
        start = int(self.starts[index])
        x = torch.from_numpy(np.ascontiguousarray(self.imu_world[start : start + self.window].T))[None]
        if self.turn_stride is None:
            return x
        angle = cyclic_angles(self.starts[index : index + 1], self.turn_stride)
        return turn_windows(x, torch.from_numpy(angle))


def window_taps(loaded: Any, model_input: ModelInput, index: int) -> dict[str, np.ndarray] | None:
    """The dashboard taps of window ``index`` (mean over ``d``, float32), or None without FDL.

    ``loaded`` is a ``ftin.checkpoint.LoadedModel``; the forward pass is stateless in eval
    mode, so it may run beside an inference on the same model in another thread.
    """
    features: dict[str, torch.Tensor] = {}
    with torch.inference_mode():
        loaded.model(loaded.normalization.apply(model_input.window_batch(index)), features=features)
    kept = {
        name: features[name][0].float().mean(dim=-1).cpu().numpy()  # drop batch, mean over d
        for name in DASHBOARD_TAPS
        if name in features
    }
    return kept or None
