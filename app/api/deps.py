"""Annotated dependencies shared by the routers."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Query, Request

from app.services import Services


def get_services(request: Request) -> Services:
    return request.app.state.services


ServicesDep = Annotated[Services, Depends(get_services)]

ModelQuery = Annotated[
    str | None,
    Query(description="Model name from GET /models; the default model when omitted.", max_length=200),
]
RunIdQuery = Annotated[
    str | None,
    Query(
        description="Optional client-chosen run id (6-64 of A-Z a-z 0-9 - _), to poll GET /runs/{run_id}"
        " for progress while the request runs.",
        max_length=64,
    ),
]
