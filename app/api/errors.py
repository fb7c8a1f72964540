"""Every error leaves the API as ``{"detail": "<plain words>"}`` with a 4xx status.

- Service errors map to statuses by kind (404 unknown, 410 a run dropped from memory, 422 unusable
  data, 413 too large, 409 taken, 504 inference over its time limit; live pushes: 401 no or wrong
  token, 403 from the LAN without a token configured, 429 too busy).
- Anything unexpected is logged with its traceback and answers 500 with the same JSON shape (bad
  input must never get there: the tests and the fuzzers hold that).
- FastAPI's validation errors become one readable sentence naming the parameter or field.
- ``BodySizeLimitMiddleware`` refuses bodies above the limit before they are parsed: from the
  ``Content-Length`` header at once, and by counting for chunked uploads. A small allowance covers
  the multipart envelope; the service then checks the file itself against the exact limit.
"""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.schemas import ErrorResponse
from app.services.errors import (
    BusyError,
    ConflictError,
    ForbiddenError,
    InferenceTimeoutError,
    InvalidInputError,
    NotFoundError,
    PayloadTooLargeError,
    RunExpiredError,
    ServiceError,
    UnauthorizedError,
)

STATUS_BY_ERROR: dict[type[ServiceError], int] = {
    NotFoundError: 404,
    RunExpiredError: 410,
    InvalidInputError: 422,
    PayloadTooLargeError: 413,
    ConflictError: 409,
    InferenceTimeoutError: 504,
    UnauthorizedError: 401,
    ForbiddenError: 403,
    BusyError: 429,
}

log = logging.getLogger("ftin.app")

MULTIPART_ALLOWANCE_BYTES = 64 * 1024


class BadRequestError(ServiceError):
    """The HTTP request itself is malformed (missing field, wrong content type): 400."""


class UnsupportedMediaError(ServiceError):
    """A body in a format the endpoint does not read: 415."""


STATUS_BY_ERROR.update({BadRequestError: 400, UnsupportedMediaError: 415})


def status_for(exc: ServiceError) -> int:
    for kind in type(exc).__mro__:
        if kind in STATUS_BY_ERROR:
            return STATUS_BY_ERROR[kind]
    return 400


def describe_validation_error(exc: RequestValidationError) -> str:
    """'query parameter model: ...; body field t_s: ...' from FastAPI's error list."""
    parts = []
    for error in exc.errors():
        loc = [str(p) for p in error.get("loc", ())]
        where = {"query": "query parameter", "path": "path parameter", "body": "body field"}.get(
            loc[0] if loc else "", "field"
        )
        name = ".".join(loc[1:]) or "(body)"
        parts.append(f"{where} {name}: {error.get('msg', 'invalid')}")
    return "; ".join(parts) or "invalid request"


def _document_validation_errors(app: FastAPI) -> None:
    """The 422 handler answers ``ErrorResponse``, not FastAPI's ``HTTPValidationError`` list: say so in
    the OpenAPI schema too (schemathesis found every documented 422 contradicting the real body)."""
    build_schema = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            schema = build_schema()  # FastAPI caches it in app.openapi_schema; edited in place once
            error_ref = {"$ref": "#/components/schemas/ErrorResponse"}
            for item in schema.get("paths", {}).values():
                for operation in item.values():
                    response = operation.get("responses", {}).get("422")
                    if response is not None:
                        response["content"] = {"application/json": {"schema": error_ref}}
            components = schema.setdefault("components", {}).setdefault("schemas", {})
            components.setdefault("ErrorResponse", ErrorResponse.model_json_schema())
            for unused in ("HTTPValidationError", "ValidationError"):
                components.pop(unused, None)
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]


def install_error_handlers(app: FastAPI) -> None:
    _document_validation_errors(app)

    @app.exception_handler(ServiceError)
    async def _service_error(_: Request, exc: ServiceError) -> JSONResponse:
        retry = getattr(exc, "retry_after_s", None)
        headers = {"Retry-After": str(retry)} if retry is not None else None
        return JSONResponse({"detail": str(exc)}, status_code=status_for(exc), headers=headers)

    @app.exception_handler(RequestValidationError)
    async def _validation_error(_: Request, exc: RequestValidationError) -> JSONResponse:
        return JSONResponse({"detail": describe_validation_error(exc)}, status_code=422)

    @app.exception_handler(Exception)
    async def _unexpected_error(request: Request, exc: Exception) -> JSONResponse:
        log.error("%s %s failed", request.method, request.url.path, exc_info=exc)
        return JSONResponse(
            {"detail": f"internal error ({type(exc).__name__}); the server log has the details"},
            status_code=500,
        )


class _BodyTooLarge(PayloadTooLargeError):
    pass


class BodySizeLimitMiddleware:
    """Pure ASGI middleware: 413 for request bodies above ``max_body_bytes``."""

    def __init__(self, app: ASGIApp, max_body_bytes: int) -> None:
        self.app = app
        self.max_body_bytes = max_body_bytes + MULTIPART_ALLOWANCE_BYTES
        self.limit_mib = max_body_bytes / 2**20

    def _message(self) -> str:
        return f"request body is larger than the {self.limit_mib:.1f} MiB upload limit (FTIN_MAX_UPLOAD_MB)"

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        for key, value in scope.get("headers", ()):
            if key == b"content-length":
                try:
                    declared = int(value)
                except ValueError:
                    declared = 0
                if declared > self.max_body_bytes:
                    await JSONResponse({"detail": self._message()}, status_code=413)(scope, receive, send)
                    return
        received = 0

        async def counting_receive() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > self.max_body_bytes:
                    # Raised inside the route's body read; the ServiceError handler answers 413.
                    raise _BodyTooLarge(self._message())
            return message

        await self.app(scope, counting_receive, send)
