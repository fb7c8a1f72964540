"""A run's first weights when they are not its own seed's: a checkpoint to fine-tune (``init_from``)
and the parameters that train while the rest stay frozen (``train_only``: a new head on a shipped
network).

Decisions:
- ``init_from`` must be the same model with the same kwargs at the same rate (JSON-compared: a
  checkpoint stores tuples as lists); with ``train_only`` it may lack exactly the parameters that
  train and the kwarg that adds them (``NEW_HEAD_KWARG``).
- Frozen parts stay in evaluation mode while the rest trains, so that they compute exactly what the
  checkpoint shipped (batch-norm statistics, dropout).
"""

from __future__ import annotations

import json

import torch

from ftin.checkpoint import CheckpointError, load_model
from ftin.models.base import VelocityModel
from ftin.train.config import ConfigError, TrainConfig

NEW_HEAD_KWARG = "uncertainty_head"  # the kwarg that adds a head a checkpoint may lack (train_only)


def initialise_from(model: VelocityModel, config: TrainConfig) -> None:
    """Copy the weights of the checkpoint ``config.init_from`` into ``model``, which must be the same
    model with the same kwargs (JSON-compared: a checkpoint stores tuples as lists) at the same rate.
    With ``train_only``, the checkpoint may lack exactly the parameters that train (a new head) and
    the kwarg that adds them (``uncertainty_head``)."""
    try:
        loaded = load_model(config.init_from)
    except CheckpointError as exc:
        raise ConfigError(f"init_from: {exc}") from None
    ours_kwargs = json.loads(json.dumps(model.config))
    theirs_kwargs = json.loads(json.dumps(loaded.model.config))
    if config.train_only:
        ours_kwargs.pop(NEW_HEAD_KWARG, None)
        theirs_kwargs.pop(NEW_HEAD_KWARG, None)
    ours = (config.model, ours_kwargs, config.imu_rate_hz)
    theirs = (loaded.model_name, theirs_kwargs, loaded.imu_rate_hz)
    if ours != theirs:
        raise ConfigError(
            f"init_from {config.init_from}: its {theirs[0]} {theirs[1]} at {theirs[2]:g} Hz cannot start "
            f"this run's {ours[0]} {ours[1]} at {ours[2]:g} Hz (give the checkpoint's model, kwargs and rate)"
        )
    missing, unexpected = model.load_state_dict(loaded.model.state_dict(), strict=not config.train_only)
    untrained = [k for k in missing if not k.startswith(config.train_only)]
    if untrained or unexpected:
        raise ConfigError(
            f"init_from {config.init_from}: weights missing {untrained[:3]}, unexpected {unexpected[:3]}"
        )


def freeze_except(model: VelocityModel, prefixes: tuple[str, ...]) -> list[torch.nn.Parameter]:
    """The parameters that train: all, or (``prefixes``) those whose names start with one of them,
    every other one frozen (``requires_grad`` off). ``keep_frozen_in_eval`` keeps their batch norms."""
    if not prefixes:
        return list(model.parameters())
    trained = []
    for name, parameter in model.named_parameters():
        parameter.requires_grad_(name.startswith(prefixes))
        if parameter.requires_grad:
            trained.append(parameter)
    if not trained:
        raise ConfigError(f"train_only {list(prefixes)}: no parameter of this model has such a name")
    return trained


def keep_frozen_in_eval(model: torch.nn.Module) -> None:
    """Put every part of ``model`` whose parameters are all frozen into evaluation mode (after
    ``train()``): frozen batch norms keep their running statistics and the dropout inside frozen parts
    is off, so the frozen part computes exactly what the checkpoint shipped."""
    for module in model.modules():
        parameters = list(module.parameters())
        if parameters and not any(p.requires_grad for p in parameters):
            module.eval()  # its children too
