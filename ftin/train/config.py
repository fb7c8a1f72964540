"""The training configuration: one typed dataclass, resolved once at the edge, saved as JSON.

Defaults follow the paper (Adam, lr 1e-4, batch 512, at most 100 epochs, MSE on velocity, learning
rate reduced on plateau, stop once it falls below 1e-6). Decisions where the paper is silent:
- Plateau schedule: RoNIN's ReduceLROnPlateau values (factor 0.1, patience 10 epochs), monitored on
  the validation velocity MSE (not the training loss, which changes meaning when an uncertainty
  model switches to NLL). Without validation data the training MSE is monitored.
- Window: 1 s (``window = imu_rate_hz`` samples); stride 10 samples (RoNIN's step).
- ``imu_rate_hz`` ``None`` means the median rate of the training data, rounded to 1 Hz; every
  sequence is resampled to it and the checkpoint records it.
- Loss ``auto``: MSE for models without uncertainty; for ``has_uncertainty`` models a Gaussian NLL
  with log-std clamped to ``log_std_range``; during the first ``nll_warmup_epochs`` epochs the
  velocity gets a pure MSE gradient and the log-std is trained on the detached error (TLIO's
  "MSE first" idea, but the uncertainty head learns from the start).
- Normalisation: none by default, as RoNIN (see ``ftin.data.windows.Normalization``).
- Early stopping (``early_stop_patience``, off by default): training ends once that many epochs in a
  row have not improved the monitored validation loss. It needs no extra resume state: the epochs
  since ``best_epoch`` tell it, so a stopped run resumed stays stopped. With an NLL loss, the count
  (and the learning-rate plateau's) starts again when the MSE warm-up ends: the switch first raises
  the validation MSE, and the NLL phase deserves the same patience.
- ``orientation``: the orientation the network is trained on (``ftin.data.orientation_option``, applied
  by ``ftin.data.prepare.prepare`` as at inference): ``ground_truth`` (motion capture / Tango: the
  network alone), ``device`` (the phone's attitude), ``vqf`` / ``vqf6d`` (VQF from the IMU) or ``auto``
  (what the app uses by default, so a model can learn on the source it will see); ``None`` keeps each
  reader's default (as configs written before the option had more choices).
- ``augment``: the augmentations beyond yaw (``ftin.train.augment``), name -> magnitude (``None``:
  its default); empty by default, as the shipped models were trained.
- ``speed_weight`` (0: off, as every shipped model): for the ``velocity`` loss, the mean squared
  error of the predicted speed ``|v|`` added with this weight. The MSE of a velocity whose direction
  is uncertain is least for a shrunken vector (the mean of vectors pointing several ways is shorter
  than each), so a model walks short where it doubts the heading; the speed term pays for the
  distance directly.
- ``rotation_consistency_weight`` (0: off, as every shipped model): each dense window is also run
  turned by a random quarter turn, and the squared difference between that velocity and the unturned
  one turned the same way is added with this weight (RIO's rotation consistency,
  ``ftin.train.rotation_consistency``); it doubles the dense windows of a forward.
- ``init_from`` (``None``: a fresh, seeded initialisation): a checkpoint (``ftin.checkpoint``) whose
  weights start the run, for fine-tuning; its model, kwargs and rate must be the run's, else the run
  refuses to start. A resumed run starts from its resume state instead.
- ``train_only`` (empty: every parameter trains): parameter-name prefixes (``log_std_head``); every
  other parameter is frozen and its modules kept in evaluation mode (batch-norm statistics unchanged),
  so a shipped checkpoint can gain a variance head while its velocities stay bit for bit. The run
  then monitors (plateau, best epoch, early stop) the validation Gaussian NLL, since the validation
  MSE of a frozen velocity cannot move; ``init_from`` may then lack the new head's weights.
- Without ``val`` paths a seeded ``val_fraction`` of the training sequences (at least one, when
  there are two or more) is held out whole, so no validation window overlaps a training window.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, fields, replace
from enum import Enum
from pathlib import Path
from typing import Any

from ftin.data.orientation_option import CHOICES as ORIENTATION_CHOICES
from ftin.data.windows import Normalization
from ftin.files import atomic_write_text
from ftin.train.augment import resolve_augment


class ConfigError(ValueError):
    """A training option has an invalid value; the message names the option."""


class LossKind(str, Enum):
    AUTO = "auto"  # MSE, or Gaussian NLL (after a warm-up) for models with uncertainty
    MSE = "mse"
    NLL = "nll"


# Options that only bound the compute of a run; a resumed run may change them.
BUDGET_FIELDS = ("max_epochs", "max_minutes", "max_steps", "device", "save_every_min")


@dataclass(frozen=True)
class TrainConfig:
    model: str
    data: tuple[str, ...]
    out_dir: str
    val: tuple[str, ...] = ()
    model_kwargs: dict[str, Any] = field(default_factory=dict)
    name: str | None = None  # checkpoint stem in out_dir; None: the model name
    imu_rate_hz: float | None = None
    window: int | None = None  # samples; None: 1 s at imu_rate_hz
    stride: int = 10
    out_dim: int | None = None  # None: the model's own default (2 for most, 3 for TLIO / RNIN)
    batch_size: int = 512
    lr: float = 1e-4
    min_lr: float = 1e-6
    plateau_factor: float = 0.1
    plateau_patience: int = 10
    max_epochs: int = 100
    max_minutes: float | None = None
    max_steps: int | None = None  # total optimizer steps (a budget, e.g. for smoke tests)
    seed: int = 0
    normalization: Normalization = Normalization.NONE
    augment_yaw: bool = True
    augment: dict[str, float | None] = field(default_factory=dict)  # ftin.train.augment
    loss: LossKind = LossKind.AUTO
    nll_warmup_epochs: int = 10
    early_stop_patience: int | None = None  # epochs without validation improvement; None: never
    orientation: str | None = None  # ftin.data.orientation_option choice, or None: the readers' default
    log_std_range: tuple[float, float] = (-5.0, 3.0)
    speed_weight: float = 0.0  # weight of the speed error beside the velocity MSE (module docstring)
    rotation_consistency_weight: float = 0.0  # RIO's turned-copy term (module docstring); 0: off
    val_fraction: float = 0.1
    device: str = "cpu"
    save_every_min: float = 5.0  # resume state is also written every so many minutes mid-epoch
    weights_dtype: str = "float32"  # storage of the best checkpoint: float32 or float16
    init_from: str | None = None  # checkpoint whose weights start the run (fine-tuning); None: seeded init
    # Walks whose truth is waypoints (ILC) in ``data``: chunks of two segments per step and the weight of
    # their segment loss beside the dense loss (ftin.train.sparse_truth); 0 chunks: such walks are refused.
    sparse_chunks: int = 4
    sparse_weight: float = 1.0
    precision: str = "fp32"  # "bf16": the forward (and so the backward) under CPU bf16 autocast
    train_only: tuple[str, ...] = ()  # parameter-name prefixes that train; empty: all (module docstring)

    def __post_init__(self) -> None:
        object.__setattr__(self, "train_only", tuple(str(p) for p in self.train_only))
        object.__setattr__(self, "data", tuple(str(p) for p in self.data))
        object.__setattr__(self, "val", tuple(str(p) for p in self.val))
        object.__setattr__(self, "log_std_range", tuple(float(v) for v in self.log_std_range))
        object.__setattr__(self, "model_kwargs", dict(self.model_kwargs))
        object.__setattr__(self, "augment", dict(self.augment or {}))
        if self.precision not in ("fp32", "bf16"):
            raise ConfigError(f"precision must be fp32 or bf16, got {self.precision!r}")
        if self.init_from is not None:
            object.__setattr__(self, "init_from", str(self.init_from))
        for name, kind in (("normalization", Normalization), ("loss", LossKind)):
            try:
                object.__setattr__(self, name, kind(getattr(self, name)))
            except ValueError:
                choices = ", ".join(k.value for k in kind)
                raise ConfigError(f"{name} must be one of {choices}, got {getattr(self, name)!r}") from None
        self._validate()

    def _validate(self) -> None:
        if not self.model:
            raise ConfigError("model: a registered model name is required")
        if not self.data:
            raise ConfigError("data: at least one training data path is required")
        _positive("batch_size", self.batch_size, integer=True)
        _positive("lr", self.lr)
        _positive("min_lr", self.min_lr)
        _positive("max_epochs", self.max_epochs, integer=True)
        _positive("stride", self.stride, integer=True)
        _positive("plateau_patience", self.plateau_patience, integer=True, allow_zero=True)
        _positive("nll_warmup_epochs", self.nll_warmup_epochs, integer=True, allow_zero=True)
        _positive("save_every_min", self.save_every_min)
        _positive("speed_weight", self.speed_weight, allow_zero=True)
        _positive("rotation_consistency_weight", self.rotation_consistency_weight, allow_zero=True)
        for name in ("imu_rate_hz", "max_minutes"):
            if getattr(self, name) is not None:
                _positive(name, getattr(self, name))
        if self.orientation is not None and self.orientation not in ORIENTATION_CHOICES:
            raise ConfigError(
                f"orientation must be one of {', '.join(ORIENTATION_CHOICES)}, got {self.orientation!r}"
            )
        for name in ("window", "max_steps", "early_stop_patience"):
            if getattr(self, name) is not None:
                _positive(name, getattr(self, name), integer=True)
        if not 0.0 < self.plateau_factor < 1.0:
            raise ConfigError(f"plateau_factor must be in (0, 1), got {self.plateau_factor}")
        if not 0.0 <= self.val_fraction < 1.0:
            raise ConfigError(f"val_fraction must be in [0, 1), got {self.val_fraction}")
        if self.out_dim is not None and self.out_dim not in (2, 3):
            raise ConfigError(f"out_dim must be 2 (horizontal velocity) or 3, got {self.out_dim}")
        if self.weights_dtype not in ("float32", "float16"):
            raise ConfigError(f"weights_dtype must be 'float32' or 'float16', got {self.weights_dtype!r}")
        try:
            resolve_augment(self.augment)
        except ValueError as exc:
            raise ConfigError(f"augment: {exc}") from None
        low, high = self.log_std_range
        if not low < high:
            raise ConfigError(f"log_std_range must be (low, high) with low < high, got {self.log_std_range}")

    @property
    def checkpoint_name(self) -> str:
        return self.name or self.model

    @property
    def resolved_window(self) -> int:
        """Window length in samples (needs ``imu_rate_hz`` resolved)."""
        if self.window is not None:
            return self.window
        if self.imu_rate_hz is None:
            raise ConfigError("window: cannot default to 1 s before imu_rate_hz is known")
        return int(round(self.imu_rate_hz))

    def with_(self, **changes: Any) -> TrainConfig:
        return replace(self, **changes)

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["normalization"] = self.normalization.value
        data["loss"] = self.loss.value
        data["data"] = list(self.data)
        data["val"] = list(self.val)
        data["log_std_range"] = list(self.log_std_range)
        data["train_only"] = list(self.train_only)
        return data

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> TrainConfig:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(
                f"unknown training option(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}"
            )
        try:
            return cls(**data)
        except TypeError as exc:  # a required option is missing
            raise ConfigError(str(exc)) from None

    def save(self, path: Path) -> None:
        atomic_write_text(path, json.dumps(self.to_json(), indent=2) + "\n")

    @classmethod
    def load(cls, path: Path) -> TrainConfig:
        try:
            data = json.loads(Path(path).read_text())
        except FileNotFoundError:
            raise ConfigError(f"{path}: no training config (not a run folder of ftin train?)") from None
        except json.JSONDecodeError as exc:
            raise ConfigError(f"{path}: not valid JSON ({exc})") from None
        if not isinstance(data, dict):
            raise ConfigError(f"{path}: expected a JSON object of training options")
        return cls.from_json(data)


def _positive(name: str, value: Any, *, integer: bool = False, allow_zero: bool = False) -> None:
    ok_type = isinstance(value, int) if integer else isinstance(value, (int, float))
    if isinstance(value, bool) or not ok_type or (not integer and not math.isfinite(value)):
        kind = "an integer" if integer else "a number"
        raise ConfigError(f"{name} must be {kind}, got {value!r}")
    if value < 0 or (value == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ConfigError(f"{name} must be {bound}, got {value}")
