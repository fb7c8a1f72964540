"""Self-describing checkpoints: ``<stem>.safetensors`` (weights) + ``<stem>.json`` (everything else).

The JSON records what ``load_model`` needs to rebuild the model and feed it (model name and
kwargs, ``imu_rate_hz``, ``window``, ``stride``, ``out_dim``, input normalisation) and what a reader
wants to know (training data, split, metrics, wall time, epochs, package version). Decisions:
- No pickle anywhere: weights are safetensors, the rest JSON (strict: non-finite floats become null).
- The JSON stores the SHA-256 of the weights file, so a pair written by different saves, or a
  corrupted weights file, is reported instead of silently loaded.
- A checkpoint says which model it belongs to in its JSON: ``model_name`` (the architecture) and
  ``tag`` (which of its weights: ``oxiod``), never by its file name (``checkpoint_tag``).
- Weights may be stored as float16 (half the size); ``load_model`` upcasts them to the model's dtype.
- Files are written atomically (``ftin.files``); the weights go first, the JSON (which names
  their hash) last.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import re
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import load as load_safetensors
from safetensors.torch import save as save_safetensors

from ftin.data.windows import InputNormalization
from ftin.files import atomic_write_bytes, atomic_write_text, to_json_safe
from ftin.models import UnknownModelError, create_model
from ftin.models.base import VelocityModel

FORMAT_VERSION = 1
WEIGHTS_SUFFIX = ".safetensors"
META_SUFFIX = ".json"
TAG = re.compile(r"[a-z0-9][a-z0-9_-]*")  # a checkpoint's ``tag``: ``oxiod``, ``pedestrian``


class CheckpointError(ValueError):
    """A checkpoint cannot be loaded: the message names the file and what is wrong."""


DEFAULT_CHOICE_FILE = "default.json"  # ftin.campaign.collect.DEFAULT_FILE: the default model and why
DEFAULT_MODEL = "ftin-pedestrian"  # without a default.json: the FTIN checkpoint trained on real walks


def read_default_choice(checkpoint_dir: Path) -> tuple[str, str] | None:
    """``(model, why)`` from the folder's ``default.json``; None without one; ``CheckpointError`` for a
    file that is not ``{"model": str, "why": str, ...}``."""
    path = checkpoint_dir / DEFAULT_CHOICE_FILE
    if not path.is_file():
        return None
    try:
        choice = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CheckpointError(f"cannot read {path}: {exc}") from exc
    if not isinstance(choice, dict) or not all(isinstance(choice.get(k), str) for k in ("model", "why")):
        raise CheckpointError(
            f'{path}: expected {{"model": NAME, "why": TEXT}} (written by `ftin campaign ship`)'
        )
    return choice["model"], choice["why"]


@dataclass(frozen=True)
class LoadedModel:
    """A model rebuilt from a checkpoint, in eval mode, with what inference needs to feed it."""

    model: VelocityModel
    name: str  # checkpoint stem, e.g. "ftin_oxiod"
    model_name: str  # registry name, e.g. "ftin"
    imu_rate_hz: float
    window: int
    stride: int
    out_dim: int
    normalization: InputNormalization
    meta: dict[str, Any]
    tag: str | None = None  # which weights of ``model_name`` these are ("oxiod"): ``checkpoint_tag``


def checkpoint_paths(path: str | Path) -> tuple[Path, Path]:
    """``(weights, json)`` paths for a checkpoint given as its .safetensors, its .json or its stem."""
    path = Path(path)
    stem = path.with_suffix("") if path.suffix in (WEIGHTS_SUFFIX, META_SUFFIX) else path
    return stem.parent / (stem.name + WEIGHTS_SUFFIX), stem.parent / (stem.name + META_SUFFIX)


def save_checkpoint(
    stem: Path, model: VelocityModel, meta: dict[str, Any], dtype: torch.dtype = torch.float32
) -> Path:
    """Write ``<stem>.safetensors`` and ``<stem>.json``; returns the weights path.

    ``meta`` must hold ``model_name``, ``imu_rate_hz`` and ``window``; ``stride`` defaults to the
    window, ``normalization`` to none. Model kwargs, ``out_dim``, format and package version, dtype
    and the weights' hash are added here.
    """
    if dtype not in (torch.float32, torch.float16):
        raise ValueError(f"dtype must be torch.float32 or torch.float16, got {dtype}")
    missing = [key for key in ("model_name", "imu_rate_hz", "window") if key not in meta]
    if missing:
        raise ValueError(f"checkpoint meta lacks {', '.join(missing)}")
    weights_path, json_path = checkpoint_paths(stem)
    tensors = {
        key: (t.detach().to("cpu", dtype) if t.is_floating_point() else t.detach().cpu()).contiguous()
        for key, t in model.state_dict().items()
    }
    header = {"format": "ftin-checkpoint", "format_version": str(FORMAT_VERSION)}
    blob = save_safetensors(tensors, metadata=header)
    normalization = meta.get("normalization", InputNormalization())
    if isinstance(normalization, InputNormalization):
        normalization = normalization.to_json()
    record = {
        **meta,
        "format_version": FORMAT_VERSION,
        "package_version": package_version(),
        "model_kwargs": dict(getattr(model, "config", {})),
        "out_dim": int(getattr(model, "out_dim", meta.get("out_dim", 2))),
        "stride": int(meta.get("stride", meta["window"])),
        "normalization": normalization,
        "weights_dtype": str(dtype).removeprefix("torch."),
        "weights_sha256": hashlib.sha256(blob).hexdigest(),
    }
    text = json.dumps(to_json_safe(record), indent=2, allow_nan=False) + "\n"
    atomic_write_bytes(weights_path, blob)
    atomic_write_text(json_path, text)
    return weights_path


def load_model(path: str | Path, device: str | torch.device = "cpu") -> LoadedModel:
    """Rebuild a model from ``path`` (.safetensors, .json or the stem); raises ``CheckpointError``."""
    weights_path, json_path = checkpoint_paths(path)
    if not weights_path.exists() and not json_path.exists():
        raise CheckpointError(
            f"{path}: no checkpoint there (expected {weights_path.name} and {json_path.name})"
        )
    if not json_path.exists():
        raise CheckpointError(
            f"{weights_path}: missing its config {json_path.name} (model name, rate, window)"
        )
    if not weights_path.exists():
        raise CheckpointError(f"{json_path}: missing its weights file {weights_path.name}")
    meta = _read_meta(json_path)
    model = _build_model(meta, json_path)
    blob = weights_path.read_bytes()
    _check_layout(blob, weights_path)
    expected_hash = meta.get("weights_sha256")
    if expected_hash and hashlib.sha256(blob).hexdigest() != expected_hash:
        raise CheckpointError(
            f"{weights_path}: contents do not match weights_sha256 in {json_path.name}; the file is "
            "corrupt or the pair comes from different saves"
        )
    try:
        tensors = load_safetensors(blob)
    except Exception as exc:  # safetensors raises its own error types for malformed files
        raise CheckpointError(f"{weights_path}: not a readable safetensors file ({exc})") from None
    _check_architecture(tensors, model, meta, weights_path)
    target = model.state_dict()
    state = {key: t.to(target[key].dtype) for key, t in tensors.items()}
    model.load_state_dict(state, strict=True)
    model.to(device).eval()
    try:
        normalization = InputNormalization.from_json(meta.get("normalization") or {})
    except ValueError as exc:
        raise CheckpointError(f"{json_path}: bad normalization ({exc})") from None
    return LoadedModel(
        model=model,
        name=weights_path.name.removesuffix(WEIGHTS_SUFFIX),
        model_name=meta["model_name"],
        imu_rate_hz=float(meta["imu_rate_hz"]),
        window=int(meta["window"]),
        stride=int(meta.get("stride", meta["window"])),
        out_dim=int(meta.get("out_dim", model.out_dim)),
        normalization=normalization,
        meta=meta,
        tag=checkpoint_tag(meta, weights_path.name.removesuffix(WEIGHTS_SUFFIX)),
    )


def checkpoint_tag(meta: dict[str, Any], stem: str) -> str | None:
    """Which weights of its model a checkpoint holds, as timm ties ``arch.tag``: ``"oxiod"`` for the
    ``ftin`` trained on OxIOD, ``""`` for a model's only weights. Its JSON's ``tag`` says so; a
    checkpoint saved before the field existed falls back on its file stem (``ftin-oxiod``: what
    follows the model's name), and one whose stem does not start with its model's name has none (None:
    it is shown by its file name)."""
    if "tag" in meta:
        return str(meta["tag"])
    model, lowered = str(meta.get("model_name", "")).lower(), stem.lower()
    if not model or not lowered.startswith(model):
        return None
    rest = stem[len(model) :]
    if rest and rest[0] not in "-_ .":
        return None  # "rnin" is not the start of "ronin_resnet-ridi": no tag rather than a wrong one
    return rest.strip("-_ .")


def package_version() -> str:
    """The installed ftin-studio version (from the distribution metadata, valid in any import mode)."""
    try:
        return importlib.metadata.version("ftin-studio")
    except importlib.metadata.PackageNotFoundError:  # running from a source tree that is not installed
        return "unknown"


# --- loading checks --------------------------------------------------------------------------------


def _read_meta(json_path: Path) -> dict[str, Any]:
    try:
        meta = json.loads(json_path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise CheckpointError(f"{json_path}: not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise CheckpointError(f"{json_path}: expected a JSON object, got {type(meta).__name__}")
    version = meta.get("format_version")
    if not isinstance(version, int) or version < 1:
        raise CheckpointError(f"{json_path}: missing or bad format_version (not a ftin checkpoint config?)")
    if version > FORMAT_VERSION:
        raise CheckpointError(
            f"{json_path}: format_version {version} is newer than this ftin understands ({FORMAT_VERSION}); "
            "upgrade ftin-studio"
        )
    missing = [key for key in ("model_name", "model_kwargs", "imu_rate_hz", "window") if key not in meta]
    if missing:
        raise CheckpointError(f"{json_path}: missing key(s) {', '.join(missing)}")
    if not isinstance(meta["model_kwargs"], dict):
        raise CheckpointError(f"{json_path}: model_kwargs must be a JSON object")
    if "tag" in meta and not (isinstance(meta["tag"], str) and TAG.fullmatch(meta["tag"])):
        raise CheckpointError(
            f"{json_path}: tag must say which weights of {meta['model_name']!r} these are in lower-case "
            f"letters, digits, '_' or '-' (e.g. \"oxiod\"), got {meta['tag']!r}"
        )
    return meta


def _build_model(meta: dict[str, Any], json_path: Path) -> VelocityModel:
    try:
        return create_model(meta["model_name"], **meta["model_kwargs"])
    except UnknownModelError as exc:
        raise CheckpointError(f"{json_path}: {exc}") from None
    except (TypeError, ValueError) as exc:
        raise CheckpointError(
            f"{json_path}: model {meta['model_name']!r} rejects model_kwargs {meta['model_kwargs']} ({exc})"
        ) from None


def _check_layout(blob: bytes, path: Path) -> None:
    """Clear messages for truncated or non-safetensors files before the parser sees them."""
    if len(blob) < 8:
        raise CheckpointError(f"{path}: truncated ({len(blob)} bytes; a safetensors file starts with 8)")
    (header_len,) = struct.unpack("<Q", blob[:8])
    if header_len > len(blob) - 8:
        raise CheckpointError(
            f"{path}: truncated or not safetensors (header declares {header_len} bytes, "
            f"file has {len(blob) - 8} after the length)"
        )
    try:
        header = json.loads(blob[8 : 8 + header_len])
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise CheckpointError(f"{path}: corrupt safetensors header (not JSON)") from None
    if not isinstance(header, dict):
        raise CheckpointError(f"{path}: corrupt safetensors header (not a JSON object)")
    ends = [
        entry["data_offsets"][1]
        for key, entry in header.items()
        if key != "__metadata__" and isinstance(entry, dict) and "data_offsets" in entry
    ]
    data_len = len(blob) - 8 - header_len
    if ends and max(ends) > data_len:
        raise CheckpointError(
            f"{path}: truncated (tensor data should be {max(ends)} bytes, file holds {data_len})"
        )


def _check_architecture(
    tensors: dict[str, torch.Tensor], model: VelocityModel, meta: dict[str, Any], path: Path
) -> None:
    expected = model.state_dict()
    missing = sorted(set(expected) - set(tensors))
    unexpected = sorted(set(tensors) - set(expected))
    mismatched = [
        f"{key} {tuple(tensors[key].shape)} in file vs {tuple(expected[key].shape)} in model"
        for key in sorted(set(expected) & set(tensors))
        if tensors[key].shape != expected[key].shape
    ]
    if not (missing or unexpected or mismatched):
        return
    problems = []
    for label, items in (("missing", missing), ("unexpected", unexpected), ("shape mismatch", mismatched)):
        if items:
            shown = ", ".join(items[:4]) + (f", ... ({len(items)} in all)" if len(items) > 4 else "")
            problems.append(f"{label}: {shown}")
    raise CheckpointError(
        f"{path}: weights do not match model {meta['model_name']!r} built with model_kwargs "
        f"{meta['model_kwargs']} ({'; '.join(problems)})"
    )
