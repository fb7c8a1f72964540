"""Live phone streams: POST /live/{format} for every push format of ``ftin.live.formats``
(/live/sensorlogger: Sensor Logger's HTTP Push), GET /live/sessions, and GET /live/info (the push URL
to type into the app). The decisions are in ``app.services.live``.

A push body's size is checked here, at the door, once (``FTIN_LIVE_MAX_BODY_KB``: 413): from its
declared length, else while it streams in, so an oversized body is never read whole."""

from __future__ import annotations

import asyncio
import socket
import time
from collections.abc import Awaitable, Callable
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request
from pydantic import BaseModel, Field
from starlette.concurrency import run_in_threadpool

from app.access import is_local, lan_addresses
from app.api.deps import ModelQuery, ServicesDep
from app.schemas import ErrorResponse
from app.services.errors import BusyError, PayloadTooLargeError
from app.services.live import PARSERS
from ftin.live.formats import DEFAULT_FORMAT, FORMATS, PushFormat

router = APIRouter(tags=["live"])

MAX_WAITING = 32  # pushes waiting for a parser before the next one gets 429
PUSH_PATH = f"/live/{DEFAULT_FORMAT.name}"  # the push URL the upload page shows

TokenQuery = Annotated[
    str | None,
    Query(
        description="The token (FTIN_TOKEN, or the one printed at start), for a push from another machine "
        "(app.access checks it, as on every route).",
        max_length=200,
    ),
]
PlatformQuery = Annotated[
    str | None,
    Query(
        description="android or ios: decides the acceleration sign when the phone streams no orientation.",
        max_length=20,
    ),
]


class LivePushResponse(BaseModel):
    status: str = "ok"
    test: bool = Field(description="True for the app's test message (Sensor Logger's 'Tap to Test Pushing').")
    detail: str | None = None
    run_id: str | None = Field(None, description="The session's run, once its first window has run.")
    queued: int | None = Field(None, description="Messages waiting to be used.")


class LiveSessionInfo(BaseModel):
    session_id: str
    device_id: str
    part: int = Field(description="2, 3, ... when a session resumed after it ended idle.")
    run_id: str | None = Field(
        description="GET /runs/{run_id}/trajectory.tum etc.; null before the first window."
    )
    name: str
    model: str
    state: str = Field(description="live, ended or failed.")
    ended_because: str | None
    silent_s: float = Field(0.0, description="Seconds since the phone's last message.")
    waiting: bool = Field(
        False, description="Live, but the phone has been silent for 2 s or more: 'waiting for the phone'."
    )
    samples: int = Field(description="Samples on the model's clock so far.")
    duration_s: float
    rate_hz: float = Field(description="The gyroscope's rate as it arrives.")
    rates_hz: dict[str, float | None] = Field(
        description="Each sensor's rate as it arrives: gyro, acc, mag (Hz; null: not streamed)."
    )
    latency_s: float | None = Field(
        description="Median from a message's arrival to the trajectory covering it."
    )
    latency_p95_s: float | None
    latest_latency_s: float | None
    messages: int
    dropped_messages: int = Field(description="Lost, or too late to use.")
    duplicate_messages: int
    distance_m: float = Field(description="Horizontal path length so far.")
    steps: int
    orientation: str | None = Field(description="device (the phone's own) or estimated (VQF online).")
    filter: str = Field("none", description="none, or ekf: the session runs through the EKF.")
    warnings: list[str]


class LiveInfoResponse(BaseModel):
    push_path: str
    local_url: str = Field(description="The push URL on this machine.")
    lan_url: str | None = Field(
        description="The push URL for a phone on the LAN (token included when shown); null when the app "
        "listens on this machine only (the note says how to make it listen on the LAN)."
    )
    token_required: bool = Field(
        description="Other machines need the token (always: one is made at start when FTIN_TOKEN is unset)."
    )
    token_shown: bool = Field(description="The token is shown only to a browser on this machine.")
    note: str
    sessions: list[LiveSessionInfo]


async def _body(request: Request, limit: int, app: str) -> bytes:
    """The request body, or 413 as soon as it is known to be over ``limit`` bytes."""
    declared = request.headers.get("content-length", "")
    size = int(declared) if declared.isdigit() else 0
    chunks: list[bytes] = []
    if size <= limit:
        size = 0
        async for chunk in request.stream():
            size += len(chunk)
            if size > limit:
                break
            chunks.append(chunk)
    if size > limit:
        raise PayloadTooLargeError(
            f"push message of {size / 1024:.0f} KiB or more; the limit is {limit / 1024:.0f} KiB "
            f"(FTIN_LIVE_MAX_BODY_KB): shorten {app}'s batch period or send fewer sensors"
        )
    return b"".join(chunks)


class _Gate:
    """At most PARSERS bodies parsed at once, at most MAX_WAITING waiting (429 beyond)."""

    def __init__(self) -> None:
        self.semaphore = asyncio.Semaphore(PARSERS)
        self.waiting = 0


def _gate(request: Request) -> _Gate:
    gate = getattr(request.app.state, "live_gate", None)
    if gate is None:
        gate = request.app.state.live_gate = _Gate()
    return gate


def _push_endpoint(push_format: PushFormat) -> Callable[..., Awaitable[LivePushResponse]]:
    """The endpoint of one push format: access, size, a parser thread, then the live service."""

    async def push(
        request: Request,
        services: ServicesDep,
        token: TokenQuery = None,
        model: ModelQuery = None,
        platform: PlatformQuery = None,
        filter: Annotated[
            str | None,
            Query(description="none (default) or ekf: a session's first push picks its filter."),
        ] = None,
    ) -> LivePushResponse:
        arrival_s = time.monotonic()
        live = services.live  # access (the token from other machines) was checked by app.access
        body = await _body(request, live.max_body_bytes, push_format.app)
        gate = _gate(request)
        if gate.waiting >= MAX_WAITING:
            raise BusyError("too many push messages at once; this one was dropped")
        gate.waiting += 1
        try:
            await gate.semaphore.acquire()
        finally:
            gate.waiting -= 1
        try:
            answer = await run_in_threadpool(
                live.accept, body, arrival_s, push_format, model, platform, filter
            )
        finally:
            gate.semaphore.release()
        return LivePushResponse(**answer)

    push.__doc__ = push_format.description
    return push


for _format in FORMATS.values():
    router.add_api_route(
        f"/live/{_format.name}",
        _push_endpoint(_format),
        methods=["POST"],
        name="push",
        summary=f"Push live sensor data ({_format.app})",
        response_model=LivePushResponse,
        responses={code: {"model": ErrorResponse} for code in (401, 403, 404, 409, 413, 422, 429)},
    )


@router.get("/live/sessions", response_model=list[LiveSessionInfo], summary="List live sessions")
async def sessions(services: ServicesDep) -> list[LiveSessionInfo]:
    """Running live sessions first, then the latest ended ones."""
    return [LiveSessionInfo(**s) for s in services.live.sessions()]


LISTEN_PROBE_S = 0.3


def listens_on(address: str, port: int) -> bool:
    """Whether this app answers on ``address`` (a connection to itself): false when it listens on
    127.0.0.1 only, which no phone can reach."""
    try:
        with socket.create_connection((address, port), timeout=LISTEN_PROBE_S):
            return True
    except OSError:
        return False


def reachable_lan_address(port: int) -> str | None:
    """The first LAN address this app answers on at ``port``, or None."""
    return next((a for a in lan_addresses() if listens_on(a, port)), None)


def _note(lan: str | None, port: int) -> str:
    if lan is None:
        return (
            "The app listens on this machine only (127.0.0.1), so a phone cannot reach it: restart it "
            f"with --host 0.0.0.0 (uvicorn app.main:app --host 0.0.0.0 --port {port}); the push URL for "
            "the phone, with the token (FTIN_TOKEN, else one generated at start), then shows here."
        )
    return (
        "Pushes from other machines must carry the token (FTIN_TOKEN, else the one generated at start: "
        "it is in the URL above, shown only on this machine)."
    )


@router.get("/live/info", response_model=LiveInfoResponse, summary="The live push URL")
def info(request: Request, services: ServicesDep) -> LiveInfoResponse:
    """The push URL to type into Sensor Logger (HTTP Push, behind the gear icon on its Logger page):
    the machine's LAN address when the app listens on it, else a note saying how to make it listen."""
    port = request.url.port or (443 if request.url.scheme == "https" else 80)
    local = is_local(request.client.host if request.client else None)
    token = request.app.state.access.token
    query = f"?token={token if local else '<FTIN_TOKEN>'}"
    lan = reachable_lan_address(port)
    body: dict[str, Any] = {
        "push_path": PUSH_PATH,
        "local_url": f"http://127.0.0.1:{port}{PUSH_PATH}{query}",
        "lan_url": None if lan is None else f"http://{lan}:{port}{PUSH_PATH}{query}",
        "token_required": True,
        "token_shown": local,
        "note": _note(lan, port),
        "sessions": [LiveSessionInfo(**s) for s in services.live.sessions()],
    }
    return LiveInfoResponse(**body)
