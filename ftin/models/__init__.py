"""All models behind one registry (``ftin.models.registry``).

Importing this package imports every public module in it, and each model family's module registers
its models (``@register_model``), so a new family is one new module here. Shared blocks live in
``ftin.models.layers``, the interface every model follows in ``ftin.models.base``.
"""

from __future__ import annotations

import importlib
import pkgutil

from ftin.models.base import VelocityModel, VelocityOutput
from ftin.models.registry import (
    ModelCfg,
    Parts,
    UnknownModelError,
    Windows,
    check_known_models,
    create_model,
    list_models,
    model_contract,
    model_label,
    model_train_options,
    register_model,
)

__all__ = [
    "ModelCfg",
    "Parts",
    "UnknownModelError",
    "VelocityModel",
    "VelocityOutput",
    "Windows",
    "check_known_models",
    "create_model",
    "list_models",
    "model_contract",
    "model_label",
    "model_train_options",
    "register_model",
]

for _module in pkgutil.iter_modules(__path__):
    if not _module.name.startswith("_"):
        importlib.import_module(f"{__name__}.{_module.name}")
