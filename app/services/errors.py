"""What can go wrong in a service call, independent of HTTP (the API maps these to status codes).

Messages are user-facing: they name the model, sequence, field or file and say what was expected.
"""

from __future__ import annotations


class ServiceError(Exception):
    """Base class; ``str(exc)`` is the message shown to the user."""


class NotFoundError(ServiceError):
    """An unknown model, sequence or run (HTTP 404)."""


class RunExpiredError(NotFoundError):
    """A run that finished here but was dropped from memory since (HTTP 410 Gone)."""


class InvalidInputError(ServiceError):
    """The request's data cannot be used: wrong schema, too short, not text (HTTP 422)."""


class PayloadTooLargeError(ServiceError):
    """The upload is above the configured limit (HTTP 413)."""


class InferenceTimeoutError(ServiceError):
    """A prediction did not finish within FTIN_INFERENCE_TIMEOUT_S (HTTP 504)."""


class ConflictError(ServiceError):
    """A client-chosen run id is already in use (HTTP 409)."""


class UnauthorizedError(ServiceError):
    """A live push without the configured token, or with a wrong one (HTTP 401)."""


class ForbiddenError(ServiceError):
    """A live push from the LAN while no token is configured (HTTP 403)."""


class BusyError(ServiceError):
    """Too many live sessions, queued messages or uploads at once: try again later (HTTP 429, with
    ``Retry-After`` where ``retry_after_s`` is given)."""

    def __init__(self, message: str, retry_after_s: int | None = None) -> None:
        super().__init__(message)
        self.retry_after_s = retry_after_s


class StartupError(RuntimeError):
    """The app cannot start with this configuration (corrupt checkpoint, missing default model)."""
