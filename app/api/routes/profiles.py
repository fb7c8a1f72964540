"""Walker profiles: ``POST /profiles/{name}/walks`` (a run of known length, or with good GPS),
``GET /profiles``, ``GET /profiles/{name}``, ``DELETE /profiles/{name}``. ``POST /predict?profile=``
applies one (``app.api.routes.predict``). The routes validate and call ``ProfileService``; step
detection for a GPS walk runs in the threadpool (plain ``def`` routes)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Response

from app.api.deps import ServicesDep
from app.schemas import ErrorResponse
from app.schemas_profiles import AddWalkRequest, ProfileResponse

router = APIRouter(tags=["profiles"])

ProfileName = Annotated[
    str, Path(description="The profile's name: 1-64 letters, digits, _ - or .", max_length=64)
]
_ERRORS = {404: {"model": ErrorResponse}, 422: {"model": ErrorResponse}}


@router.get("/profiles", response_model=list[ProfileResponse], summary="List the walker profiles")
def list_profiles(services: ServicesDep) -> list[ProfileResponse]:
    """Every walker profile, by name."""
    return [ProfileResponse.from_profile(p) for p in services.profiles.list()]


@router.get(
    "/profiles/{name}", response_model=ProfileResponse, responses=_ERRORS, summary="Read a walker profile"
)
def get_profile(name: ProfileName, services: ServicesDep) -> ProfileResponse:
    return ProfileResponse.from_profile(services.profiles.get(name))


@router.post(
    "/profiles/{name}/walks",
    response_model=ProfileResponse,
    summary="Add a walk of known length to a walker profile",
    responses={**_ERRORS, 400: {"model": ErrorResponse}, 410: {"model": ErrorResponse}},  # 400: bad JSON
)
def add_walk(name: ProfileName, body: AddWalkRequest, services: ServicesDep) -> ProfileResponse:
    """Add a finished run as a walk of known length (``distance_m``; without it, its GPS path where the
    GPS is good enough) to the profile ``name``, created with its first walk; the profile as it is now."""
    return ProfileResponse.from_profile(services.profiles.add_walk(name, body.run_id, body.distance_m))


@router.delete("/profiles/{name}", status_code=204, responses=_ERRORS, summary="Delete a walker profile")
def delete_profile(name: ProfileName, services: ServicesDep) -> Response:
    services.profiles.delete(name)
    return Response(status_code=204)
