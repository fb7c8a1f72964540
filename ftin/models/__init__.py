"""All models behind one registry. Importing this package registers every family."""

from ftin.models import ftin_net, imunet, rnin, ronin, tlio  # noqa: F401  (registration side effects)
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
    "register_model",
]
