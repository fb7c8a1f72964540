"""timm-style model registry: ``create_model(name, **cfg)`` and ``list_models()``."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from torch import nn

_MODELS: dict[str, Callable[..., nn.Module]] = {}

F = TypeVar("F", bound=Callable[..., nn.Module])


def register_model(name: str) -> Callable[[F], F]:
    """Decorator: make a model factory (or class) available to ``create_model(name)``."""

    def decorate(factory: F) -> F:
        if name in _MODELS:
            raise ValueError(f"model {name!r} registered twice")
        _MODELS[name] = factory
        return factory

    return decorate


def list_models() -> list[str]:
    return sorted(_MODELS)


class UnknownModelError(KeyError):
    def __str__(self) -> str:  # KeyError quotes its message; keep it readable
        return str(self.args[0])


def create_model(name: str, **cfg) -> nn.Module:
    """Build a registered model; ``cfg`` overrides its default configuration."""
    try:
        factory = _MODELS[name]
    except KeyError:
        raise UnknownModelError(
            f"unknown model {name!r}; valid models: {', '.join(list_models())}"
        ) from None
    return factory(**cfg)
