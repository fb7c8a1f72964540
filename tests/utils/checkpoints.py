"""Tiny real checkpoints for tests: one factory instead of a helper (and its constants) per folder.

``write_checkpoint(stem, model_name, ...)`` seeds torch, builds a registered model with tiny
settings (``tiny_model_kwargs``) or the ``model_kwargs`` given, and saves it with ``save_checkpoint``
(safetensors + JSON), so every checkpoint a test loads went through the real writer. The
``make_checkpoint`` fixture in ``tests/conftest.py`` calls it in a fresh temporary folder.
``tiny_train_config`` is the training config that makes such checkpoints with ``ftin.train``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch

from ftin.checkpoint import save_checkpoint
from ftin.models import create_model
from ftin.models.ftin_net import TINY_FTIN_KWARGS
from ftin.train.config import TrainConfig

RATE_HZ = 50.0  # the simulated walks' rate in most tests
WINDOW = 25  # 0.5 s at RATE_HZ
STRIDE = 5
TINY_TCN = {"channels": (8, 8)}
TINY_LSTM = {"hidden_size": 8, "num_layers": 2}


def tiny_model_kwargs(model_name: str, window: int = WINDOW) -> dict[str, Any]:
    """Small settings of a registered model (fast to build and run on a CPU), for ``window`` samples."""
    if model_name in ("ftin", "resnet_fdl", "resnet_tdl", "resnet1d"):
        return {**TINY_FTIN_KWARGS, "window": window}
    if model_name == "ronin_resnet":
        return {"window": window, "blocks_per_group": (1, 1, 1, 1), "trans_channels": 8, "fc_dim": 16}
    if model_name == "ronin_tcn":
        return dict(TINY_TCN)
    if model_name == "ronin_lstm":
        return dict(TINY_LSTM)
    raise KeyError(f"no tiny settings for {model_name!r}: pass model_kwargs")


def write_checkpoint(
    stem: Path,
    model_name: str = "ronin_tcn",
    *,
    seed: int = 0,
    rate_hz: float = RATE_HZ,
    window: int = WINDOW,
    stride: int = STRIDE,
    model_kwargs: dict[str, Any] | None = None,
    **meta: Any,
) -> Path:
    """Save an untrained tiny ``model_name`` as ``<stem>.safetensors`` + ``<stem>.json``; ``meta``
    adds fields to the JSON (``training_data``, ``metrics``, ...). Returns the safetensors path."""
    torch.manual_seed(seed)
    kwargs = tiny_model_kwargs(model_name, window) if model_kwargs is None else model_kwargs
    model = create_model(model_name, **kwargs)
    fields = {"model_name": model_name, "imu_rate_hz": rate_hz, "window": window, "stride": stride, **meta}
    return save_checkpoint(stem, model, fields)


def tiny_train_config(out_dir: Path, **changes: Any) -> TrainConfig:
    """A training config that runs in seconds on the simulated walks: a tiny TCN at ``WINDOW``
    samples, batch 64, lr 1e-3, two epochs, seed 7; ``changes`` override any field."""
    base: dict[str, Any] = dict(
        model="ronin_tcn",
        model_kwargs={"channels": (8, 8), "kernel_size": 3},
        data=("sim",),
        out_dir=str(out_dir),
        window=WINDOW,
        stride=STRIDE,
        batch_size=64,
        lr=1e-3,
        max_epochs=2,
        seed=7,
    )
    return TrainConfig(**{**base, **changes})


def head_train_config(out_dir: Path, source: Path, max_epochs: int) -> TrainConfig:
    """Stage three's recipe on a tiny RoNIN ResNet: a log-std head trained alone on the frozen
    network of the checkpoint at ``source`` (``ftin train --train-only log_std_head --init-from``)."""
    return tiny_train_config(
        out_dir,
        model="ronin_resnet",
        model_kwargs={**tiny_model_kwargs("ronin_resnet"), "uncertainty_head": True},
        init_from=str(source),
        train_only=("log_std_head",),
        max_epochs=max_epochs,
    )
