"""``uvicorn app.main:app``: the REST API, the upload page at ``/`` and the viser 3D scene.

Start-up (the lifespan) loads every checkpoint once, lists the data folders and starts the viser
server; shutdown stops viser and its threads. ``create_app(settings)`` builds an app for tests.
``app.access`` guards every route (token, ``Host``, cross-site) and keeps secrets out of the access log.

The OpenAPI page at ``/docs`` serves Swagger UI from the ``fastapi-offline`` package, because
FastAPI's default page loads it from a CDN and the dashboard must work offline. ReDoc is not offered.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import torch
from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.staticfiles import StaticFiles
from fastapi_offline import FastAPIOffline
from starlette.concurrency import run_in_threadpool

import ftin
from app.access import (
    AccessMiddleware,
    AccessPolicy,
    announce,
    deprecation_notes,
    install_log_redaction,
    uvicorn_cli_bind,
)
from app.api.errors import BodySizeLimitMiddleware, install_error_handlers
from app.api.routes import exports, health, live, metrics, models, pages, predict, profiles, runs, sequences
from app.api.routes.pages import STATIC_DIR
from app.services import Services
from app.services.errors import StartupError
from app.settings import Settings

log = logging.getLogger("ftin.app")


@asynccontextmanager
async def lifespan(app: FastAPI) -> AsyncIterator[None]:
    settings: Settings = app.state.settings
    threads_before = torch.get_num_threads()
    if settings.torch_threads:
        torch.set_num_threads(settings.torch_threads)
    scene = services = None
    try:
        try:
            services = await run_in_threadpool(Services.build, settings)
        except StartupError as exc:
            log.error("FTIN Studio cannot start: %s", exc)
            raise
        for note in [*deprecation_notes(), *services.notes]:
            log.warning("%s", note)
        bind = uvicorn_cli_bind()  # None under another launcher (serve_in_thread announces itself)
        if bind is not None:
            announce(app.state.access, *bind)
        if settings.viser_enabled:
            from app.viz.scene import DashboardScene  # deferred: viser loads only when the scene is enabled

            scene = DashboardScene.start(
                services, settings.viser_host, settings.viser_port, settings.scene_first_run
            )
            services.scene_url = scene.url
        app.state.services, app.state.scene = services, scene
        yield
    finally:
        if services is not None:
            services.live.stop()  # running live sessions end as runs
            services.runs.flush()  # every finished run on disk before the app goes (written behind answers)
        if scene is not None:
            scene.stop()
        app.state.scene = None
        torch.set_num_threads(threads_before)


def create_app(settings: Settings | None = None) -> FastAPI:
    app = FastAPIOffline(
        title="FTIN Studio",
        version=ftin.__version__,
        description="Inertial odometry: IMU recording in, walked trajectory out. The 3D scene runs "
        "beside the API (see GET /health for its URL).",
        lifespan=lifespan,
        redoc_url=None,
    )
    app.state.settings = settings or Settings()
    if app.state.settings.cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=app.state.settings.cors_origins,
            allow_methods=["GET", "POST", "DELETE"],
        )
    app.add_middleware(BodySizeLimitMiddleware, max_body_bytes=app.state.settings.max_upload_bytes)
    app.state.access = AccessPolicy.from_settings(app.state.settings)
    app.add_middleware(AccessMiddleware, policy=app.state.access)  # the outermost: checked first
    install_log_redaction()
    install_error_handlers(app)
    for module in (health, models, metrics, sequences, predict, runs, exports, live, profiles, pages):
        app.include_router(module.router)
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    return app


app = create_app()
