"""All models behind one registry. Importing this package registers every family."""

from ftin.models import ftin_net, imunet, rnin, ronin, tlio  # noqa: F401  (registration side effects)
from ftin.models.base import VelocityModel, VelocityOutput
from ftin.models.registry import UnknownModelError, create_model, list_models, register_model

__all__ = [
    "UnknownModelError",
    "VelocityModel",
    "VelocityOutput",
    "create_model",
    "list_models",
    "register_model",
]
