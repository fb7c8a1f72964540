"""A 3D scene on a real viser server (OS-assigned port), for the tests of ``app.viz``."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from app.services import Services
from app.settings import Settings
from app.viz.scene import DashboardScene


@contextmanager
def running_scene(settings: Settings) -> Iterator[DashboardScene]:
    """The scene over services built from ``settings``, linked from their answers as the app links it;
    the live service and the server stop on exit."""
    services = Services.build(settings)
    dashboard = DashboardScene.start(services, "127.0.0.1", 0)
    services.scene_url = dashboard.url
    try:
        yield dashboard
    finally:
        services.live.stop()
        dashboard.stop()


def empty_scene(scene: DashboardScene) -> None:
    """Wait for what is queued to be drawn, then clear the scene: each test starts from an empty one."""
    scene.flush()
    scene.gui_clear_scene()
