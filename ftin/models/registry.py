"""timm-style model registry: ``create_model(name, **options)``, ``list_models()`` and each model's
input contract, ``model_contract(name) -> ModelCfg`` (timm's ``default_cfg``), known without building.

The contract says what a model takes and gives (``ftin.models.base`` has the interface itself):

* windows: its default window (samples) and the IMU rate that window is meant for, and which other
  windows it accepts: ``Windows.FIXED`` (layer sizes depend on ``L``: built for the ``window``
  option, it accepts only that length), ``Windows.MULTIPLE`` (any ``L >= min_window`` that is a
  multiple of ``window_multiple``; RNIN's multiple is its ``sub_window`` option) or ``Windows.ANY``
  (any ``L >= min_window``: the sequence-to-sequence RoNIN LSTM and TCN);
* outputs: ``out_dim`` by default, whether it has an uncertainty (log-std) head, its parts per
  window (``Parts``), whether it streams, and the loss its family trains with.

``create_model(name, window=L, out_dim=D, ...)`` is the one way to build a model for a window:
``window`` goes into the config of ``FIXED`` models and is checked against the contract of the others
(``ValueError`` naming the requirement). Decision: a *contract option* (``window``, ``out_dim``) that a
model does not take is dropped silently, so that generic callers (training, profiling, the
benchmark) can pass the same options to every model; the model's ``config`` (what checkpoints store)
never holds a dropped key. Any other key a model does not know is still an error, raised by the
model's config (``ValueError``/``TypeError`` naming the valid keys), so misspellings are caught.

Beside its contract, each registration carries what belongs to the model and not to any one caller:
its display name (``label``, ``model_label``: one spelling for the app, the reports and the figures)
and its reference training recipe (``train_options``, ``model_train_options``: ``TrainConfig``
option overrides at a given IMU rate, e.g. RNIN's ten 1 s sub-windows and batch 32; none for a model
that trains with the protocol's defaults).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any, TypeVar

from torch import nn

# Options every caller may pass to any model; a model that does not take one ignores it.
CONTRACT_OPTIONS = frozenset({"window", "out_dim"})


class Windows(str, Enum):
    FIXED = "fixed"  # built for the ``window`` option; accepts only that length
    MULTIPLE = "multiple"  # any L >= min_window with L % window_multiple == 0
    ANY = "any"  # any L >= min_window


class Parts(str, Enum):
    """What ``forward_parts`` predicts for one window (``ftin.models.base``)."""

    WINDOW = "window"  # K = 1: the window's velocity
    SUB_WINDOW = "sub_window"  # K = L / sub_window (RNIN)
    FRAME = "frame"  # K = L: one velocity per frame (RoNIN LSTM / TCN)


@dataclass(frozen=True)
class ModelCfg:
    """A registered model's input contract (module docstring); ``config`` is its config dataclass."""

    config: type
    window: int  # default window in samples
    rate_hz: float  # the IMU rate the default window is meant for
    windows: Windows = Windows.FIXED
    min_window: int = 1
    window_multiple: int | str = 1  # a number, or the config option that holds it
    uncertainty: bool = False
    parts: Parts = Parts.WINDOW
    streams: bool = False
    train_loss: str = "velocity"  # a loss name in ftin.train.losses

    @property
    def options(self) -> tuple[str, ...]:
        """The config keys the model takes."""
        return tuple(f.name for f in dataclasses.fields(self.config))

    def takes(self, option: str) -> bool:
        return option in self.options

    def default(self, option: str) -> Any:
        """The default value of a config option (``KeyError`` for one the model does not take)."""
        for f in dataclasses.fields(self.config):
            if f.name == option:
                return f.default if f.default is not dataclasses.MISSING else f.default_factory()
        raise KeyError(option)

    @property
    def out_dim(self) -> int:
        return int(self.default("out_dim"))

    def multiple(self, options: dict[str, Any] | None = None) -> int:
        """``window_multiple`` for a model built with ``options``."""
        options = options or {}
        if isinstance(self.window_multiple, str):
            return int(options.get(self.window_multiple, self.default(self.window_multiple)))
        return self.window_multiple

    def window_error(self, window: int, options: dict[str, Any] | None = None) -> str | None:
        """Why a model built with ``options`` cannot take ``window`` samples, or None.

        ``FIXED`` models are built for the window, so only their config can reject it (when built).
        """
        if self.windows is Windows.FIXED:
            return None
        multiple = self.multiple(options)
        minimum = max(self.min_window, multiple) if self.windows is Windows.MULTIPLE else self.min_window
        if window < minimum or window % multiple:
            return f"window must be >= {minimum} and a multiple of {multiple}, got {window}"
        return None


# The IMU rate (whole Hz) -> ``TrainConfig`` options the model's reference trains with.
TrainOptions = Callable[[int], dict[str, Any]]


@dataclass(frozen=True)
class _Entry:
    factory: Callable[..., nn.Module]
    cfg: ModelCfg
    label: str
    train_options: TrainOptions | None


_ENTRIES: dict[str, _Entry] = {}

ModelFactory = TypeVar("ModelFactory", bound=Callable[..., nn.Module])


def register_model(
    name: str, cfg: ModelCfg, *, label: str, train_options: TrainOptions | None = None
) -> Callable[[ModelFactory], ModelFactory]:
    """Decorator: make a model factory (or class), its contract, its display name and its training
    recipe (module docstring) available under ``name``."""

    def decorate(factory: ModelFactory) -> ModelFactory:
        if name in _ENTRIES:
            raise ValueError(f"model {name!r} registered twice")
        _ENTRIES[name] = _Entry(factory, cfg, label, train_options)
        return factory

    return decorate


def list_models() -> list[str]:
    return sorted(_ENTRIES)


class UnknownModelError(KeyError):
    def __str__(self) -> str:  # KeyError quotes its message; keep it readable
        return str(self.args[0])


def check_known_models(names: list[str] | tuple[str, ...]) -> None:
    """Raise ``UnknownModelError`` (with the valid names) for the first unregistered name."""
    for name in names:
        if name not in _ENTRIES:
            raise UnknownModelError(f"unknown model {name!r}; valid models: {', '.join(list_models())}")


def model_contract(name: str) -> ModelCfg:
    """The input contract of a registered model, without building it."""
    check_known_models([name])
    return _ENTRIES[name].cfg


def model_label(name: str) -> str:
    """How people know a registered model: ``"RoNIN ResNet"``, ``"ResNet + TDL"``."""
    check_known_models([name])
    return _ENTRIES[name].label


def model_train_options(name: str, rate_hz: int) -> dict[str, Any]:
    """The ``TrainConfig`` options a registered model's reference trains with at ``rate_hz`` ({} when
    the protocol's defaults serve it)."""
    check_known_models([name])
    train_options = _ENTRIES[name].train_options
    return train_options(rate_hz) if train_options is not None else {}


def create_model(name: str, **options: Any) -> nn.Module:
    """Build a registered model; ``options`` override its default configuration.

    ``window`` and ``out_dim`` are dropped for a model that does not take them; a ``window`` its
    contract does not accept raises ``ValueError`` (module docstring).
    """
    contract = model_contract(name)
    if "window" in options and not contract.takes("window"):
        problem = contract.window_error(int(options["window"]), options)
        if problem:
            raise ValueError(f"{name}: {problem}")
    dropped = {key for key in CONTRACT_OPTIONS if key in options and not contract.takes(key)}
    return _ENTRIES[name].factory(**{k: v for k, v in options.items() if k not in dropped})
