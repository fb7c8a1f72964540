"""Training: typed config, one loop for every model, pickle-free resume state.

The checkpoint API (``load_model``, ``save_checkpoint``, ``LoadedModel``, ``CheckpointError``) lives in
``ftin.checkpoint``; it is re-exported here, as before, for callers of ``ftin.train``.
"""

from ftin.checkpoint import CheckpointError, LoadedModel, load_model, save_checkpoint
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
