"""A bundled sample predicted with no model named (``POST /sequences/{id}/predict``) runs the model
``GET /sequences`` suggests for it, the shipped ``ftin-sim``, and walks right: it covers 0.85-1.15 of the
walk and ends at most half as far from the truth as standing still would (ATE, RoNIN convention)."""

from __future__ import annotations

import pytest
import torch
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from tests.utils.paths import CHECKPOINTS


@pytest.fixture(scope="module")
def shipped_client():
    if not (CHECKPOINTS / "ftin-sim.safetensors").is_file():
        pytest.skip(f"no shipped ftin-sim checkpoint in {CHECKPOINTS}")
    torch.set_num_threads(1)
    settings = Settings(checkpoint_dir=CHECKPOINTS, viser_enabled=False, scene_first_run=False)
    with TestClient(create_app(settings)) as client:
        yield client


def test_every_bundled_sample_runs_its_suggested_model_and_walks(shipped_client: TestClient) -> None:
    listed = shipped_client.get("/sequences").json()
    assert len(listed) == 4
    for sequence in listed:
        response = shipped_client.post(f"/sequences/{sequence['id']}/predict")
        assert response.status_code == 200, response.text
        body = response.json()
        assert body["model"] == sequence["suggested_model"] == "ftin-sim"
        assert body["model_choice"]["rule"] == "sequence"
        metrics = body["metrics"]
        assert 0.85 <= metrics["path_length_ratio"] <= 1.15, (sequence["name"], metrics["path_length_ratio"])
        still = metrics["stand_still"]["ate"]
        assert metrics["ate"] <= 0.5 * still, (sequence["name"], metrics["ate"], still)
