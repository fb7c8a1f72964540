"""Config and input checks shared by the model families, so every model words its errors the same way."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

import torch

C = TypeVar("C")


def make_config(config_cls: type[C], model_name: str, cfg: dict[str, Any]) -> C:
    """Build ``config_cls(**cfg)``, naming the model and the valid keys when a key is unknown."""
    valid = [f.name for f in dataclasses.fields(config_cls)]
    unknown = sorted(set(cfg) - set(valid))
    if unknown:
        raise ValueError(
            f"{model_name}: unknown config key(s) {', '.join(map(repr, unknown))}; "
            f"valid keys: {', '.join(valid)}"
        )
    return config_cls(**cfg)


def require(condition: bool, model_name: str, message: str) -> None:
    """Raise ``ValueError('<model>: <message>')`` when a config value is out of range."""
    if not condition:
        raise ValueError(f"{model_name}: {message}")


def require_ranges(
    config: Any, model_name: str, at_least: Mapping[str, int], fractions: Sequence[str] = ()
) -> None:
    """The range checks every family's config makes: each field of ``at_least`` no smaller than its
    bound (sizes, counts), each of ``fractions`` in [0, 1) (dropout), in that order."""
    for name, low in at_least.items():
        value = getattr(config, name)
        require(value >= low, model_name, f"{name} must be >= {low}, got {value}")
    for name in fractions:
        value = getattr(config, name)
        require(0.0 <= value < 1.0, model_name, f"{name} must be in [0, 1), got {value}")


def check_input(
    x: torch.Tensor,
    model_name: str,
    *,
    in_channels: int = 6,
    window: int | None = None,
    min_window: int = 1,
    window_multiple: int = 1,
) -> int:
    """Validate a ``(B, in_channels, L)`` batch and return ``L``.

    ``window`` is set for models whose layer sizes depend on the window length: they accept only
    that ``L`` and the message says how to rebuild the model for another one.
    """
    if x.ndim != 3 or x.shape[1] != in_channels:
        raise ValueError(f"{model_name}: expected input of shape (B, {in_channels}, L), got {tuple(x.shape)}")
    length = int(x.shape[2])
    if window is not None and length != window:
        raise ValueError(
            f"{model_name}: built for window={window} samples, got L={length}; "
            f"rebuild it with create_model({model_name!r}, window={length})"
        )
    if length < min_window or length % window_multiple:
        raise ValueError(
            f"{model_name}: window length L={length} must be >= {min_window} "
            f"and a multiple of {window_multiple}"
        )
    return length
