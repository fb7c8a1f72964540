"""The run folder of a training run, and its resume state saved without pickle.

A run folder (``ftin.train.loop``) holds ``config.json`` (the resolved ``TrainConfig``, checked
against the options of a resumed run), ``resume.safetensors`` (below), ``history.json`` (one record
per finished epoch) and the best checkpoint.

One file, ``resume.safetensors``: every tensor (model weights and buffers, optimizer moments and
step counts, the torch RNG state) is a safetensors tensor, and everything else (scheduler state,
optimizer hyper-parameters, numpy and Python RNG states, progress counters) is JSON stored in the
safetensors header metadata. A single file written atomically means a run killed while saving
keeps its previous, consistent state.

The JSON encoding is explicit about what plain JSON loses: tensors become ``{"__tensor__": key}``,
dicts with integer keys (optimizer state) ``{"__int_keys__": ...}``, tuples (RNG states)
``{"__tuple__": [...]}``, numpy arrays ``{"__ndarray__": [...], "dtype": ...}`` and non-finite floats
(the plateau scheduler's initial ``best = inf``) ``{"__float__": "inf"}``.

The ``progress`` entry is ``TrainProgress.to_dict()``: ten keys, in the order of its fields, as
written since the first resume files (a file written by older code loads with ``from_dict``).
"""

from __future__ import annotations

import json
import math
import random
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors import safe_open
from safetensors.torch import save as save_safetensors
from torch import nn

from ftin.checkpoint import CheckpointError, checkpoint_tag
from ftin.files import atomic_write_bytes, to_json_safe, write_json
from ftin.train.config import BUDGET_FIELDS, ConfigError, TrainConfig

CONFIG_FILE = "config.json"
RESUME_FILE = "resume.safetensors"
HISTORY_FILE = "history.json"

STATE_FORMAT = "ftin-resume-state"
STATE_VERSION = 1
_META_KEY = "ftin_resume_state"


def _monitored(record: dict[str, Any]) -> float:
    """An epoch record's monitored loss: the validation MSE, else the training loss."""
    return record["val_mse"] if record["val_mse"] is not None else record["train_loss"]


@dataclass
class TrainProgress:
    """Where a run stands; the resume file's ``progress`` entry (field names and order are the format)."""

    epoch: int = 0  # finished epochs
    step_in_epoch: int = 0  # optimizer steps done in the current epoch
    global_step: int = 0  # optimizer steps over the whole run
    epoch_loss_sum: float = 0.0  # sum of batch loss x batch size in the current epoch (this rank)
    epoch_count: int = 0  # windows behind epoch_loss_sum
    best_val_loss: float | None = None  # the monitored loss of the best epoch
    best_epoch: int | None = None  # 1-based epoch of the best checkpoint
    elapsed_s: float = 0.0  # wall time over every invocation, up to the last save
    history: list[dict[str, Any]] = field(default_factory=list)  # one record per finished epoch
    stop_reason: str | None = None  # None while running; see ftin.train.loop.TrainResult

    def stalled(self, patience: int | None, loss_switch: int | None = None) -> bool:
        """``patience`` finished epochs in a row without a new best (derived from the history, not
        stored). After a loss switch (``loss_switch`` epochs of MSE, then TLIO's NLL) the count starts
        from the best epoch of the new phase: the switch first raises the validation MSE, and the NLL
        phase gets the same patience as the MSE one (TLIO's reference has no early stop at all)."""
        if patience is None or self.best_epoch is None:
            return False
        best = self.best_epoch
        phase = [h for h in self.history if loss_switch is not None and h["epoch"] > loss_switch]
        if phase:
            best = min(phase, key=_monitored)["epoch"]
        return self.epoch - best >= patience

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainProgress:
        unknown = sorted(set(data) - {f.name for f in fields(cls)})
        if unknown:
            raise CheckpointError(f"resume progress has unknown key(s) {unknown}")
        return cls(**data)


# --- the run folder ---------------------------------------------------------------------------------


def check_run_folder(out_dir: Path, resume: bool) -> None:
    """A new run needs a folder without a run in it; ``--resume`` one with a resume state."""
    if resume and not (out_dir / RESUME_FILE).exists():
        raise ConfigError(f"--resume: {out_dir} has no {RESUME_FILE} to continue from")
    if not resume and (out_dir / RESUME_FILE).exists():
        raise ConfigError(
            f"--out {out_dir} already holds a run; pass --resume to continue it or choose another folder"
        )


def check_resumed_config(config: TrainConfig, out_dir: Path) -> None:
    """A resumed run must have the options it started with, budgets (``BUDGET_FIELDS``) aside."""
    saved = TrainConfig.load(out_dir / CONFIG_FILE)
    # Compare as JSON: tuples in model_kwargs come back from config.json as lists.
    ours = {k: v for k, v in _as_json(config.to_json()).items() if k not in BUDGET_FIELDS}
    theirs = {k: v for k, v in _as_json(saved.to_json()).items() if k not in BUDGET_FIELDS}
    changed = sorted(k for k in ours if ours[k] != theirs.get(k))
    if changed:
        details = ", ".join(f"{k}: {theirs.get(k)!r} -> {ours[k]!r}" for k in changed)
        raise ConfigError(f"--resume: the run in {out_dir} was started with other options ({details})")


def checkpoint_meta(
    config: TrainConfig,
    progress: TrainProgress,
    normalization: Any,
    data_info: dict[str, Any],
    partial: bool,
    *,
    processes: int,
    wall_time_s: float,
) -> dict[str, Any]:
    """The run's part of its best checkpoint's JSON (``ftin.checkpoint.save_checkpoint`` adds the
    model's); ``metrics`` are those of the last finished epoch, ``partial`` before any ended."""
    last = progress.history[-1] if progress.history else {}
    # Which weights of the model these are, said in the card from here on (never read off a file name
    # again): what the run's name says after the model's ("ftin-oxiod" -> "oxiod").
    tag = checkpoint_tag({"model_name": config.model}, config.checkpoint_name)
    return {
        "model_name": config.model,
        **({"tag": tag} if tag else {}),  # none for a run named as its model: its only weights
        "imu_rate_hz": config.imu_rate_hz,
        "window": config.window,
        "stride": config.stride,
        "out_dim": config.out_dim,
        "normalization": normalization,
        **data_info,
        "metrics": {
            "val_mse": last.get("val_mse"),
            "train_loss": last.get("train_loss"),
            "monitored_loss": progress.best_val_loss,
            "epoch": progress.best_epoch,
            "partial": partial,
        },
        "epochs": progress.epoch,
        "steps": progress.global_step,
        "processes": processes,
        "wall_time_s": wall_time_s,
        "train_config": config.to_json(),
    }


def write_history(out_dir: Path, history: list[dict[str, Any]]) -> None:
    write_json(out_dir / HISTORY_FILE, history)


def _as_json(value: Any) -> Any:
    return json.loads(json.dumps(to_json_safe(value)))


# --- the resume state -------------------------------------------------------------------------------


def capture_rng() -> dict[str, Any]:
    """The global RNG states a training step can consume: torch (CPU), numpy and Python."""
    return {"torch": torch.get_rng_state(), "numpy": np.random.get_state(), "python": random.getstate()}


def restore_rng(state: dict[str, Any]) -> None:
    torch.set_rng_state(state["torch"])
    np.random.set_state(state["numpy"])
    random.setstate(state["python"])


def save_training_state(
    path: Path,
    *,
    model: nn.Module,
    optimizer: torch.optim.Optimizer,
    scheduler: Any,
    progress: dict[str, Any],
    rng: dict[str, Any] | None = None,
) -> None:
    """Write everything needed to continue the run exactly where it stands."""
    tensors: dict[str, torch.Tensor] = {}
    record = {
        "format": STATE_FORMAT,
        "version": STATE_VERSION,
        "model": _encode(model.state_dict(), "model", tensors),
        "optimizer": _encode(optimizer.state_dict(), "optimizer", tensors),
        "scheduler": _encode(scheduler.state_dict(), "scheduler", tensors),
        "rng": _encode(capture_rng() if rng is None else rng, "rng", tensors),
        "progress": _encode(progress, "progress", tensors),
    }
    tensors = {key: t.detach().cpu().contiguous() for key, t in tensors.items()}
    blob = save_safetensors(tensors, metadata={_META_KEY: json.dumps(record)})
    atomic_write_bytes(Path(path), blob)


def load_training_state(
    path: Path, *, model: nn.Module, optimizer: torch.optim.Optimizer, scheduler: Any
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Load model, optimizer and scheduler state in place; return ``(progress, rng)`` (not applied)."""
    path = Path(path)
    if not path.exists():
        raise CheckpointError(f"{path}: no resume state (the run folder has no {path.name})")
    try:
        with safe_open(str(path), framework="pt") as handle:
            metadata = handle.metadata() or {}
            tensors = {key: handle.get_tensor(key) for key in handle.keys()}
        record = json.loads(metadata[_META_KEY])
    except KeyError:
        raise CheckpointError(f"{path}: not a ftin resume state (no {_META_KEY} metadata)") from None
    except Exception as exc:  # truncated or corrupt file: safetensors raises its own error types
        raise CheckpointError(f"{path}: unreadable resume state ({exc})") from None
    if record.get("format") != STATE_FORMAT or record.get("version") != STATE_VERSION:
        raise CheckpointError(
            f"{path}: unsupported resume state {record.get('format')!r} version {record.get('version')}"
        )
    try:
        model.load_state_dict(_decode(record["model"], tensors), strict=True)
        optimizer.load_state_dict(_decode(record["optimizer"], tensors))
        scheduler.load_state_dict(_decode(record["scheduler"], tensors))
    except (RuntimeError, ValueError, KeyError) as exc:
        raise CheckpointError(
            f"{path}: resume state does not fit this run's model or optimizer ({exc})"
        ) from None
    return _decode(record["progress"], tensors), _decode(record["rng"], tensors)


def _encode(value: Any, key: str, tensors: dict[str, torch.Tensor]) -> Any:
    if isinstance(value, torch.Tensor):
        tensors[key] = value
        return {"__tensor__": key}
    if isinstance(value, dict):
        if value and all(isinstance(k, int) for k in value):
            return {"__int_keys__": {str(k): _encode(v, f"{key}/{k}", tensors) for k, v in value.items()}}
        return {str(k): _encode(v, f"{key}/{k}", tensors) for k, v in value.items()}
    if isinstance(value, tuple):
        return {"__tuple__": [_encode(v, f"{key}/{i}", tensors) for i, v in enumerate(value)]}
    if isinstance(value, list):
        return [_encode(v, f"{key}/{i}", tensors) for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return {"__ndarray__": value.tolist(), "dtype": str(value.dtype)}
    if isinstance(value, np.generic):
        return _encode(value.item(), key, tensors)
    if isinstance(value, float) and not math.isfinite(value):
        return {"__float__": repr(value)}
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise TypeError(f"cannot store {type(value).__name__} at {key!r} in a resume state")


def _decode(value: Any, tensors: dict[str, torch.Tensor]) -> Any:
    if isinstance(value, list):
        return [_decode(v, tensors) for v in value]
    if not isinstance(value, dict):
        return value
    if "__tensor__" in value:
        return tensors[value["__tensor__"]]
    if "__int_keys__" in value:
        return {int(k): _decode(v, tensors) for k, v in value["__int_keys__"].items()}
    if "__tuple__" in value:
        return tuple(_decode(v, tensors) for v in value["__tuple__"])
    if "__ndarray__" in value:
        return np.asarray(value["__ndarray__"], dtype=value["dtype"])
    if "__float__" in value:
        return float(value["__float__"])
    return {k: _decode(v, tensors) for k, v in value.items()}
