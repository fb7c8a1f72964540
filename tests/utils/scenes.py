"""A 3D scene on a real viser server (OS-assigned port), for the tests of ``app.viz``."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np
import pytest

from app.services import Services
from app.settings import Settings
from app.viz.framing import DEFAULT_CANVAS_PX
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


def module_scene(**overrides: object) -> Callable[..., Iterator[DashboardScene]]:
    """A test module's ``scene`` fixture: one running scene for the module, its settings the app
    fixtures' (``make_settings``) with ``overrides``. In a module: ``scene = module_scene()``."""

    @pytest.fixture(scope="module")
    def scene(make_settings: Callable[..., Settings]) -> Iterator[DashboardScene]:
        with running_scene(make_settings(**overrides)) as dashboard:
            yield dashboard

    return scene


def emptied_for_each_test() -> Callable[[DashboardScene], None]:
    """An autouse fixture that empties the module's ``scene`` before each test:
    ``_empty_scene = emptied_for_each_test()``."""

    @pytest.fixture(autouse=True)
    def _empty_scene(scene: DashboardScene) -> None:
        empty_scene(scene)

    return _empty_scene


def screen_point(
    point: np.ndarray, eye: np.ndarray, target: np.ndarray, fov: float
) -> tuple[float, float, float]:
    """CSS ``(x, y)`` of ``point`` on the scene's default canvas and its depth along the view (m), for a
    pinhole camera at ``eye`` looking at ``target`` with +z up (``fov``: vertical, radians)."""
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = point - eye
    width, height = DEFAULT_CANVAS_PX
    focal = (height / 2) / np.tan(fov / 2)
    depth = float(d @ forward)
    return width / 2 + float(d @ right) / depth * focal, height / 2 - float(d @ up) / depth * focal, depth
