"""Walker profiles: POST /profiles/{name}/walks, GET /profiles(/{name}), DELETE /profiles/{name}, and
POST /predict?profile= (app/api/routes/profiles.py, ftin.profiles)."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import Settings
from tests.app.routes.helpers import detail, upload
from tests.app.test_plausibility_api import sensorlogger_zip
from tests.utils.gps import northward_fixes, twenty_steps_export
from tests.utils.paths import CHECKPOINTS


def path_of(body: dict) -> float:
    t = body["trajectory"]
    return float(np.hypot(np.diff(t["x"]), np.diff(t["y"])).sum())


def end_of(body: dict) -> np.ndarray:
    t = body["trajectory"]
    return np.array([t["x"][-1] - t["x"][0], t["y"][-1] - t["y"][0]])


def real_settings(make_settings: Callable[..., Settings]) -> Settings:
    """The shipped checkpoints (the default model): a real walk's path is metres long, as a profile's
    walk must be (the tiny fixtures barely move); an empty runs folder of its own."""
    return make_settings(checkpoint_dir=CHECKPOINTS, default_model="ronin_resnet-walking")


@pytest.fixture
def fresh(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    """An app with its own empty runs folder: its profiles are its own."""
    with TestClient(create_app(real_settings(make_settings))) as client:
        yield client


def test_a_walk_of_known_length_makes_a_profile_that_scales_the_path(
    fresh: TestClient, csv_without_gt: bytes
) -> None:
    plain = upload(fresh, csv_without_gt, "walk.csv").json()
    predicted = path_of(plain)
    assert "profile" not in plain  # an answer without a profile is as it was
    added = fresh.post(
        "/profiles/anna/walks", json={"run_id": plain["run_id"], "distance_m": 1.3 * predicted}
    )
    assert added.status_code == 200, added.text
    profile = added.json()
    assert profile["name"] == "anna" and profile["scale"] == pytest.approx(1.3, rel=1e-3)
    assert profile["walks"][0]["source"] == "distance" and profile["walks"][0]["run_id"] == plain["run_id"]
    assert profile["scale_sigma"] > profile["log_spread"] > 0  # one walk: the prior, widened by the mean's
    assert fresh.get("/profiles/anna").json() == profile
    assert [p["name"] for p in fresh.get("/profiles").json()] == ["anna"]

    scaled = upload(fresh, csv_without_gt, "walk.csv", profile="anna").json()
    assert scaled["profile"]["name"] == "anna" and scaled["profile"]["scale"] == pytest.approx(1.3, rel=1e-3)
    assert path_of(scaled) == pytest.approx(1.3 * predicted, rel=1e-3)
    assert end_of(scaled) == pytest.approx(1.3 * end_of(plain), rel=1e-3, abs=1e-6)
    assert np.allclose(scaled["velocity"]["vx"], 1.3 * np.asarray(plain["velocity"]["vx"]), atol=1e-9)
    # the walker's own spread (9 %) is narrower than the population's: a smaller circle, said so
    assert scaled["uncertainty"]["end_radius_95_m"] < 1.3 * plain["uncertainty"]["end_radius_95_m"]
    assert "profile" in scaled["uncertainty"]["calibration"]
    # the run keeps its profile: its result again, after the answer, and its metrics.json
    assert fresh.get(f"/runs/{scaled['run_id']}/result").json()["profile"] == scaled["profile"]
    assert fresh.get(f"/runs/{scaled['run_id']}/metrics.json").json()["profile"]["name"] == "anna"

    # a profiled run teaches the same scale: the model's own path, not the scaled one, is divided
    again = fresh.post(
        "/profiles/anna/walks", json={"run_id": scaled["run_id"], "distance_m": 1.3 * predicted}
    )
    assert again.json()["scale"] == pytest.approx(1.3, rel=1e-3) and len(again.json()["walks"]) == 2


def test_the_same_run_again_replaces_its_walk(fresh: TestClient, csv_without_gt: bytes) -> None:
    run = upload(fresh, csv_without_gt).json()
    predicted = path_of(run)
    fresh.post("/profiles/bo/walks", json={"run_id": run["run_id"], "distance_m": 2 * predicted})
    profile = fresh.post("/profiles/bo/walks", json={"run_id": run["run_id"], "distance_m": predicted}).json()
    assert len(profile["walks"]) == 1 and profile["scale"] == pytest.approx(1.0, rel=1e-3)


def test_unknown_profiles_are_404s_that_name_them(fresh: TestClient, csv_without_gt: bytes) -> None:
    listed = fresh.get("/sequences").json()[0]["id"]
    for response in (
        upload(fresh, csv_without_gt, profile="nobody"),
        fresh.post(f"/sequences/{listed}/predict", params={"profile": "nobody"}),
        fresh.get("/profiles/nobody"),
        fresh.delete("/profiles/nobody"),
    ):
        assert response.status_code == 404 and "nobody" in detail(response)


def test_delete_removes_the_profile(fresh: TestClient, csv_without_gt: bytes) -> None:
    run = upload(fresh, csv_without_gt).json()
    fresh.post("/profiles/gone/walks", json={"run_id": run["run_id"], "distance_m": path_of(run)})
    assert fresh.delete("/profiles/gone").status_code == 204
    assert fresh.get("/profiles/gone").status_code == 404 and fresh.get("/profiles").json() == []


def test_bad_names_and_inputs_are_4xx_json(fresh: TestClient, csv_without_gt: bytes) -> None:
    run = upload(fresh, csv_without_gt).json()
    run_id, predicted = run["run_id"], path_of(run)
    cases = [
        ("/profiles/-dash/walks", {"run_id": run_id, "distance_m": 10.0}, 422, "profile name"),
        ("/profiles/ok/walks", {"run_id": run_id, "distance_m": -3}, 422, "distance_m"),
        ("/profiles/ok/walks", {"run_id": run_id, "distance_m": 50 * predicted}, 422, "outside"),
        ("/profiles/ok/walks", {"run_id": run_id, "distance_m": 5.0}, 422, "too short"),
        ("/profiles/ok/walks", {"distance_m": 10.0}, 422, "run_id"),
        ("/profiles/ok/walks", {"run_id": "no-such-run", "distance_m": 10.0}, 404, "no-such-run"),
        # an IMU-only CSV has no GPS: its length must be given
        ("/profiles/ok/walks", {"run_id": run_id}, 422, "needs distance_m"),
    ]
    for url, body, status, words in cases:
        response = fresh.post(url, json=body)
        assert response.status_code == status, (body, response.text)
        assert words in detail(response)
    assert fresh.get("/profiles").json() == []  # nothing refused was kept


def test_profiles_survive_a_restart(make_settings: Callable[..., Settings], csv_without_gt: bytes) -> None:
    settings = real_settings(make_settings)
    with TestClient(create_app(settings)) as first:
        run = upload(first, csv_without_gt).json()
        made = first.post("/profiles/kept/walks", json={"run_id": run["run_id"], "distance_m": path_of(run)})
    with TestClient(create_app(settings)) as second:
        assert second.get("/profiles/kept").json() == made.json()


def test_a_run_with_good_gps_counts_by_itself(fresh: TestClient, shared_data: Path) -> None:
    real_client = fresh
    export = twenty_steps_export(shared_data)
    plain = upload(real_client, sensorlogger_zip(export, None), "walk.zip").json()
    # fixes a second walking north at a pace that makes the GPS path 1.4 times the predicted one
    seconds = 21
    speed = max(1.4 * path_of(plain), 25.0) / (seconds - 1)
    walk = upload(real_client, sensorlogger_zip(export, northward_fixes(export, seconds, speed)), "walk.zip")
    run = walk.json()
    gps = {r["code"]: r for r in run["verdict"]["reasons"]}["gps_path"]["figures"]
    added = real_client.post("/profiles/gps-walker/walks", json={"run_id": run["run_id"]})
    assert added.status_code == 200, added.text
    walk_row = added.json()["walks"][0]
    assert walk_row["source"] == "gps"
    assert walk_row["distance_m"] == pytest.approx(gps["gps_path_m"], abs=0.1)
    assert added.json()["scale"] == pytest.approx(gps["gps_path_m"] / gps["model_m"], rel=0.01)
    assert math.isfinite(added.json()["scale_sigma"])


def test_a_profile_on_another_models_prediction_warns(fresh: TestClient, csv_without_gt: bytes) -> None:
    run = upload(fresh, csv_without_gt).json()
    assert run["model"] == "ronin_resnet-walking"
    made = fresh.post(
        "/profiles/eve/walks", json={"run_id": run["run_id"], "distance_m": path_of(run)}
    ).json()
    assert made["walks"][0]["model"] == "ronin_resnet-walking"
    same = upload(fresh, csv_without_gt, profile="eve").json()
    assert not any("reads distance its own way" in w for w in same["warnings"])
    other = upload(fresh, csv_without_gt, profile="eve", model="ftin-pedestrian").json()
    assert any("ftin-pedestrian reads distance its own way" in w for w in other["warnings"])
