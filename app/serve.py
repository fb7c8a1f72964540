"""The app under uvicorn in a background thread, on a port the OS picks: one way to run it in-process
for the live-server tests, the benchmarks and the screenshot script (``uvicorn app.main:app``
serves it for real)."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

import uvicorn
from fastapi import FastAPI

from app.access import announce


class ServerStartError(RuntimeError):
    """uvicorn stopped (or did not answer in time) before it listened."""


@dataclass
class ThreadedServer:
    app: FastAPI
    server: uvicorn.Server
    thread: threading.Thread
    base_url: str  # http://127.0.0.1:<port>

    @property
    def scene(self) -> Any:  # app.viz.scene.DashboardScene, or None without the 3D scene
        return self.app.state.scene

    def stop(self, timeout_s: float = 30.0) -> bool:
        """Ask uvicorn to exit and wait for its thread; False if it is still running."""
        self.server.should_exit = True
        self.thread.join(timeout_s)
        return not self.thread.is_alive()


def serve_in_thread(
    app: FastAPI,
    host: str = "127.0.0.1",
    timeout_s: float = 60.0,
    name: str = "ftin-uvicorn",
    log_level: str = "warning",
) -> ThreadedServer:
    """Start ``app`` (its lifespan included) on ``host`` and a free port; return once it listens
    (bound beyond loopback: having printed the URL other machines open, with the token)."""
    config = uvicorn.Config(app, host=host, port=0, log_level=log_level, lifespan="on")
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, name=name, daemon=True)
    thread.start()
    deadline = time.monotonic() + timeout_s
    while not server.started:
        if not thread.is_alive() or time.monotonic() > deadline:
            raise ServerStartError("uvicorn did not start (see the log above)")
        time.sleep(0.02)
    port = server.servers[0].sockets[0].getsockname()[1]
    announce(app.state.access, host, port)
    return ThreadedServer(app, server, thread, f"http://{host}:{port}")
