"""All models behind one registry (``ftin.models.registry``).

Importing this package imports every public module in it, and each model family's module registers
its models (``@register_model``), so a new family is one new module here. Shared blocks live in
``ftin.models.layers``, the interface every model follows in ``ftin.models.base``.
"""

from __future__ import annotations

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
from ftin.submodules import import_submodules

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

import_submodules(__name__, __path__)
