"""An honest 95 % circle in the API (issue 52): no radius on an implausible walk (the reason instead),
with ground truth whether the true end lies inside the radius, and the coverage figure labelled as
measured on validation walks (``ftin.uncertainty.end_circle``).

The shipped default runs on the bundled simulated hand-held walk (its first 60 s); its ground truth is
given as recorded, or stretched three-fold from its start (a truth that walks three times farther
than the model reads, so that its end lies far outside the circle). The fixture's tiny untrained
model barely moves: its verdict is implausible.
"""

from __future__ import annotations

import io
from collections.abc import Callable, Iterator

import numpy as np
import pandas as pd
import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.settings import BUNDLED_SAMPLES_DIR, Settings
from ftin.uncertainty.calibration import calibration_for
from ftin.uncertainty.radius import radius_holding
from tests.app.routes.helpers import upload
from tests.utils.paths import CHECKPOINTS

IMU = ["t", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z", "q_w", "q_x", "q_y", "q_z"]
GT = ["gt_device_world_x", "gt_device_world_y", "gt_device_world_z"]


@pytest.fixture(scope="module")
def shipped(make_settings: Callable[..., Settings]) -> Iterator[TestClient]:
    settings = make_settings(checkpoint_dir=CHECKPOINTS, default_model="ronin_resnet-walking")
    with TestClient(create_app(settings)) as client:
        yield client


def sample(truth_scale: float | None = None, seconds: float = 60.0) -> bytes:
    """The bundled hand-held walk's first ``seconds``; its ground truth scaled about its start by
    ``truth_scale`` (None: without ground truth)."""
    walk = pd.read_csv(BUNDLED_SAMPLES_DIR / "sim_handheld.csv")
    walk = walk[walk["t"] < seconds]
    if truth_scale is None:
        return walk[IMU].to_csv(index=False).encode()
    gt = walk[GT].to_numpy()
    walk[GT] = gt[0] + truth_scale * (gt - gt[0])
    return walk[[*IMU, *GT]].to_csv(index=False).encode()


def end_cov(answer: dict) -> np.ndarray:
    traj = answer["trajectory"]
    return np.array([[traj["cov_xx"][-1], traj["cov_xy"][-1]], [traj["cov_xy"][-1], traj["cov_yy"][-1]]])


def test_a_walk_judged_plausible_gets_its_radius_and_says_what_the_coverage_means(
    shipped: TestClient,
) -> None:
    answer = upload(shipped, sample(), "walk.csv").json()
    found = answer["uncertainty"]
    assert answer["verdict"]["level"] != "implausible"
    assert found["end_radius_95_m"] == pytest.approx(radius_holding(end_cov(answer)), abs=0.01)
    assert found["withheld_reason"] is None and found["true_end_inside"] is None  # no truth: unknown
    assert "not measured on this run" in found["coverage_text"]
    assert calibration_for("ronin_resnet-walking").fitted_on in found["coverage_text"]
    [reason] = [r for r in answer["verdict"]["reasons"] if r["code"] == "end_radius"]
    assert reason["figures"]["end_radius_95_m"] == pytest.approx(found["end_radius_95_m"], abs=0.01)
    metrics = shipped.get(f"/runs/{answer['run_id']}/metrics.json").json()
    assert metrics["uncertainty"] == found


def test_an_implausible_walk_gets_no_radius_but_the_reason(client: TestClient, csv_without_gt: bytes) -> None:
    answer = upload(client, csv_without_gt, "phone.csv").json()  # the fixture model barely moves
    verdict, found = answer["verdict"], answer["uncertainty"]
    assert verdict["level"] == "implausible"
    assert found["end_radius_95_m"] is None
    assert "implausible" in found["withheld_reason"] and "barely moves" in found["withheld_reason"]
    assert "end_radius" not in {r["code"] for r in verdict["reasons"]} and "(95 %)" not in verdict["says"]
    assert answer["trajectory"]["cov_xx"] is not None  # the covariance itself is still answered
    assert client.get(f"/runs/{answer['run_id']}/metrics.json").json()["uncertainty"] == found
    table = pd.read_csv(io.StringIO(client.get(f"/runs/{answer['run_id']}/trajectory.csv").text), comment="#")
    assert "sigma_x_m" in table.columns


def test_with_truth_the_answer_says_whether_the_true_end_lies_inside(shipped: TestClient) -> None:
    recorded = upload(shipped, sample(1.0), "walk.csv").json()
    found = recorded["uncertainty"]
    assert recorded["verdict"]["level"] != "implausible"
    assert isinstance(found["true_end_inside"], bool)
    assert found["true_end_inside"] is (found["true_end_error_m"] <= found["end_radius_95_m"])
    stretched = upload(shipped, sample(3.0), "walk.csv").json()  # the truth walks three times farther
    far = stretched["uncertainty"]
    assert stretched["verdict"]["level"] == "check"  # a path a third of the truth's: told, not withheld
    assert far["end_radius_95_m"] is not None and far["true_end_error_m"] > far["end_radius_95_m"]
    assert far["true_end_inside"] is False
