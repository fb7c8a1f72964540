"""One local Ray (two CPUs) for every test of the engine: starting one costs seconds."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def ray_local():
    ray = pytest.importorskip("ray", reason="the campaign engine needs the [cluster] extra (ray)")
    ray.init(
        address="local", num_cpus=2, logging_level="WARNING", log_to_driver=False, include_dashboard=False
    )
    yield ray
    ray.shutdown()
