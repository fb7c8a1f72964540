"""schemathesis against the app's own OpenAPI schema, in-process over ASGI (no network, lifespan
run, tiny checkpoint): for every operation, in both generation modes (schema-conforming and not),
requests must never get a 5xx, and answers must match the documented status codes, content types
and response schemas.

Decisions:
- Operations are drawn through ``APIOperation.as_strategy`` inside our own hypothesis test, not
  through ``schemathesis.pytest.from_fixture``: that lazy loader reads a private pytest attribute
  that pytest 9 removed (AttributeError ``_nodeid``), and this keeps the same profile and counter
  as the other fuzzers.
- Checks left out on purpose: ``positive_data_acceptance`` (a schema-valid JSON recording of random
  numbers is still refused, rightly, by the data checks: unsorted time, no gravity) and the
  stateful/auth checks (``use_after_free``, ``ignored_auth``, ...): the in-process client is on
  this machine, which needs no token (``app.access``: ``tests/app/test_access.py`` tests it), and a
  deleted run answering 404 is ``tests/app/routes/test_run_delete.py``'s.
"""

from __future__ import annotations

import pytest
import schemathesis
from hypothesis import given, settings
from hypothesis import strategies as st
from schemathesis.checks import (
    content_type_conformance,
    not_a_server_error,
    response_schema_conformance,
    status_code_conformance,
)
from schemathesis.generation.modes import GenerationMode

from app.main import create_app
from app.settings import Settings

PROFILE = settings.get_profile("ftin-fuzz")
CHECKS = [not_a_server_error, status_code_conformance, content_type_conformance, response_schema_conformance]
# (method, path, mode) from the schema itself (building the app runs no lifespan: nothing loads).
# Negative mode needs something to break: operations without parameters or body get positive only.
CASES = [
    (method.upper(), path, mode)
    for path, item in create_app(Settings(viser_enabled=False)).openapi()["paths"].items()
    for method, operation in item.items()
    for mode in GenerationMode
    if mode is GenerationMode.POSITIVE or operation.get("parameters") or operation.get("requestBody")
]


@pytest.fixture(scope="module")
def api_schema(hardening_settings):
    return schemathesis.openapi.from_asgi("/openapi.json", create_app(hardening_settings))


@pytest.mark.parametrize(("method", "path", "mode"), CASES, ids=[f"{m} {p} {g}" for m, p, g in CASES])
@settings(PROFILE)
@given(data=st.data())
def test_openapi_operation(method, path, mode, data, api_schema, case_counter):
    case = data.draw(api_schema[path][method].as_strategy(generation_mode=mode), label="case")
    response = case.call_and_validate(checks=CHECKS)
    case_counter.add("schemathesis", f"{mode} {response.status_code}")


def test_documented_422_is_the_error_body_the_app_sends():
    """Found by schemathesis: FastAPI documented every 422 as its ``HTTPValidationError`` list, while
    the app answers ``{"detail": "<plain words>"}``."""
    schema = create_app(Settings(viser_enabled=False)).openapi()
    documented = [
        operation["responses"]["422"]["content"]["application/json"]["schema"]
        for item in schema["paths"].values()
        for operation in item.values()
        if "422" in operation["responses"]
    ]
    assert documented and all(s == {"$ref": "#/components/schemas/ErrorResponse"} for s in documented)
    assert "HTTPValidationError" not in schema["components"]["schemas"]
