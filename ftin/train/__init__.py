"""Training: typed config, one loop for every model, checkpoints and pickle-free resume state."""

from ftin.train.checkpoint import CheckpointError, LoadedModel, load_model, save_checkpoint
from ftin.train.config import ConfigError, LossKind, TrainConfig
from ftin.train.loop import TrainResult, run_training, train

__all__ = [
    "CheckpointError",
    "ConfigError",
    "LoadedModel",
    "LossKind",
    "TrainConfig",
    "TrainResult",
    "load_model",
    "run_training",
    "save_checkpoint",
    "train",
]
