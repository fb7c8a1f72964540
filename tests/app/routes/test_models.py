"""GET /models (app/api/routes/models.py) and the model name every prediction route takes."""

from __future__ import annotations

from fastapi.testclient import TestClient

from tests.app.routes.helpers import DEFAULT_MODEL, OTHER_MODEL, detail, upload


def test_models_lists_checkpoints_with_their_facts(client: TestClient) -> None:
    models = {m["name"]: m for m in client.get("/models").json()}
    assert set(models) == {DEFAULT_MODEL, OTHER_MODEL}
    ftin = models[DEFAULT_MODEL]
    assert ftin["architecture"] == "ftin" and models[OTHER_MODEL]["architecture"] == "resnet1d"
    assert ftin["default"] is True and models[OTHER_MODEL]["default"] is False
    assert ftin["imu_rate_hz"] == 100.0 and ftin["window"] == 50 and ftin["stride"] == 25
    assert ftin["trained_on"] == "simulated walks (test fixture)"
    assert models[OTHER_MODEL]["trained_on"] == "simulated walks (2 sequences)"  # no developer path
    assert ftin["metrics"] == {"ate": 1.5, "rte": 2.5, "pde": 0.05}
    assert ftin["parameters"] > 1000 and ftin["out_dim"] == 2
    # Menus show the name people know; a stem that names no architecture is shown as it is.
    assert ftin["display_name"] == "FTIN · OxIOD" and models[OTHER_MODEL]["display_name"] == OTHER_MODEL


def test_display_names_come_from_the_checkpoints_tag() -> None:
    from app.services.model_names import display_name

    assert display_name("rnin-oxiod", "rnin", "oxiod") == "RNIN · OxIOD"  # never "min-oxiod"
    assert display_name("ftin-pedestrian", "ftin", "pedestrian") == "FTIN · pedestrian"
    assert display_name("ronin_resnet-ridi", "ronin_resnet", "ridi") == "RoNIN ResNet · RIDI"
    assert display_name("ftin-sim", "ftin", "sim") == "FTIN · simulated walks"
    assert display_name("renamed", "ftin", "oxiod") == "FTIN · OxIOD"  # the file's name plays no part
    assert display_name("ftin", "ftin", "") == "FTIN"
    assert display_name("my_model", "ftin", None) == "my_model"  # no tag: shown by its file name


def test_unknown_model_is_404_naming_the_valid_ones(client: TestClient, csv_with_gt: bytes) -> None:
    response = upload(client, csv_with_gt, model="NoSuchModel")
    assert response.status_code == 404
    message = detail(response)
    assert "NoSuchModel" in message and DEFAULT_MODEL in message and OTHER_MODEL in message
