"""Resume state of a training run, saved without pickle.

One file, ``resume.safetensors``: every tensor (model weights and buffers, optimizer moments and
step counts, the torch RNG state) is a safetensors tensor, and everything else (scheduler state,
optimizer hyper-parameters, numpy and Python RNG states, progress counters) is JSON stored in the
safetensors header metadata. A single file written atomically means a run killed while saving
keeps its previous, consistent state.

The JSON encoding is explicit about what plain JSON loses: tensors become ``{"__tensor__": key}``,
dicts with integer keys (optimizer state) ``{"__int_keys__": ...}``, tuples (RNG states)
``{"__tuple__": [...]}``, numpy arrays ``{"__ndarray__": [...], "dtype": ...}`` and non-finite floats
(the plateau scheduler's initial ``best = inf``) ``{"__float__": "inf"}``.
"""

from __future__ import annotations

import json
import math
import random
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors import safe_open
from safetensors.torch import save as save_safetensors
from torch import nn

from ftin.train.checkpoint import CheckpointError, atomic_write_bytes

STATE_FORMAT = "ftin-resume-state"
STATE_VERSION = 1
_META_KEY = "ftin_resume_state"


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
